# End to end: simulate `small` (detections only) -> a registration -> lookboth
# evaluate, snapshot (PNG sizes read from the files' headers) and report.
#   cmake -DLOOKBOTH=<exe> -DREGISTER=truth|lookboth -DTRUTH_TOOL=<exe> -DWORK_DIR=<dir>
#         -DMAX_POSITION_M=<m> -DMAX_ROTATION_DEG=<deg> -P report_e2e.cmake
# REGISTER=truth: the registration is written from the ground truth by a test
# tool (evaluate must then find zero error); REGISTER=lookboth: by `lookboth register`
# with the metric (wheel odometry) trajectory; the RMS errors evaluate prints
# must stay within MAX_POSITION_M and MAX_ROTATION_DEG.
file(REMOVE_RECURSE "${WORK_DIR}")
file(MAKE_DIRECTORY "${WORK_DIR}")

function(run)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE code OUTPUT_VARIABLE out ERROR_VARIABLE err
    WORKING_DIRECTORY "${WORK_DIR}")
  message("$ ${ARGN}\n${out}${err}")
  if(NOT code EQUAL 0)
    message(FATAL_ERROR "exit code ${code}: ${ARGN}")
  endif()
  set(output "${out}${err}" PARENT_SCOPE)
endfunction()

function(expect regex)
  if(NOT output MATCHES "${regex}")
    message(FATAL_ERROR "output does not match '${regex}'")
  endif()
endfunction()

# width x height of a PNG, from its IHDR chunk (bytes 16-23, big-endian).
function(png_size file out_var)
  file(READ "${file}" header HEX OFFSET 16 LIMIT 8)
  string(SUBSTRING "${header}" 0 8 w)
  string(SUBSTRING "${header}" 8 8 h)
  math(EXPR w "0x${w}")
  math(EXPR h "0x${h}")
  set(${out_var} "${w}x${h}" PARENT_SCOPE)
endfunction()

# The whole scenario (36 s; detections only: under a second).
run(${LOOKBOTH} simulate --scenario small --detections-only --out small.rawlog)
if(REGISTER STREQUAL "truth")
  run(${TRUTH_TOOL} small.rawlog reg 0.1 -0.05 0.05)
else()
  run(${LOOKBOTH} register small.rawlog --out reg --trajectory metric)
endif()

run(${LOOKBOTH} evaluate reg --ground-truth small.rawlog)
expect("Against ground truth")
expect("alignment: SE\\(3\\) over 6 cameras")
expect("paper's Table I")
expect("wrote reg/evaluation.json")
if(NOT EXISTS "${WORK_DIR}/reg/evaluation.json")
  message(FATAL_ERROR "no evaluation.json")
endif()
if(REGISTER STREQUAL "truth")
  expect("RMS +0\\.0000 +0\\.000 ")
endif()
# The RMS row's position error [m], bounded.
string(REGEX MATCH "\n  RMS +([0-9.]+) +([0-9.]+)" rms "${output}")
if(NOT rms OR CMAKE_MATCH_1 GREATER MAX_POSITION_M OR CMAKE_MATCH_2 GREATER MAX_ROTATION_DEG)
  message(FATAL_ERROR "position/rotation RMS out of bounds: '${rms}'")
endif()

run(${LOOKBOTH} snapshot small.rawlog reg --out pictures --size 800x450 --ground-truth small.rawlog)
expect("fisheye_check_f[0-9]+_t[0-9.]+s.png +\\(800x450\\)")
expect("overview_3d.png +\\(800x450\\)")
expect("compare_top_side_vs_ground_truth.png")
file(GLOB pngs "${WORK_DIR}/pictures/*.png")
list(LENGTH pngs count)
if(count LESS 4)
  message(FATAL_ERROR "only ${count} pictures")
endif()
foreach(png IN LISTS pngs)
  png_size("${png}" size)
  if(NOT size STREQUAL "800x450")
    message(FATAL_ERROR "${png} is ${size}, expected 800x450")
  endif()
endforeach()

run(${LOOKBOTH} report small.rawlog reg --out report.html --ground-truth small.rawlog)
expect("verdict: ")
expect("open it in a browser: file://")
file(READ "${WORK_DIR}/report.html" html)
string(REGEX MATCHALL "data:image/png;base64," images "${html}")
list(LENGTH images image_count)
if(image_count LESS 4)
  message(FATAL_ERROR "report.html embeds ${image_count} pictures")
endif()
