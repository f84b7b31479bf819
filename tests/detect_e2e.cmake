# lookboth detect end to end on a tiny simulated dataset: two shards by
# camera, joined by convert --merge, then in place with --evaluate, and a
# bad camera label.
file(REMOVE_RECURSE "${WORK_DIR}")
file(MAKE_DIRECTORY "${WORK_DIR}")

function(run expect_exit)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err
    WORKING_DIRECTORY "${WORK_DIR}")
  message("$ ${ARGN}\n${out}${err}")
  if(NOT rc EQUAL expect_exit)
    message(FATAL_ERROR "exit code ${rc}, expected ${expect_exit}")
  endif()
  set(out "${out}${err}" PARENT_SCOPE)
endfunction()

function(expect regex)
  if(NOT out MATCHES "${regex}")
    message(FATAL_ERROR "output does not match '${regex}'")
  endif()
endfunction()

run(0 ${LOOKBOTH} simulate --scenario small --duration 2 --out tiny.rawlog --threads 2)
# Shard 1: the marker in cam03; shard 2: cam04 and the fisheye's blobs.
run(0 ${LOOKBOTH} detect tiny.rawlog --cameras cam03 --out a.rawlog --threads 2)
expect("cam03: [0-9]+ frames, [1-9][0-9]* markers")
expect("wrote .*a.rawlog: [1-9][0-9]* marker observations, 0 blob records")
run(0 ${LOOKBOTH} detect tiny.rawlog --cameras cam04,fisheye --out b.rawlog --threads 1)
expect("fisheye: [0-9]+ frames, [1-9][0-9]* blobs")
run(0 ${LOOKBOTH} convert --merge a.rawlog b.rawlog --to merged.rawlog)
expect("wrote merged.rawlog: .*blobs: [1-9].*marker: [1-9]")
# The input is untouched by --out; in place with --evaluate it gains detections.
run(0 ${LOOKBOTH} convert --from tiny.rawlog --to tiny_before.tum --label ground_truth)
run(0 ${LOOKBOTH} detect tiny.rawlog --evaluate)
expect("markers vs ground truth: recall [1-9][0-9]*/[1-9][0-9]*")
expect("blobs vs ground truth: ")
run(0 ${LOOKBOTH} convert --from tiny.rawlog --to tiny_folder)
expect("marker: [1-9]")
# Errors: an unknown camera, a dataset that does not exist.
run(1 ${LOOKBOTH} detect tiny.rawlog --cameras nope)
expect("lookboth: error: .*tiny.rawlog.*--cameras.*no camera with this label.*nope")
run(1 ${LOOKBOTH} detect missing.rawlog)
expect("lookboth: error: missing.rawlog: no such file or folder")
