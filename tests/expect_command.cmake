# Runs a command and checks its exit code and output.
#   cmake -DCOMMAND="a;b;c" -DEXPECT_EXIT=0 -DEXPECT_REGEX="..." [-DWORK_DIR=...] -P expect_command.cmake
# EXPECT_REGEX is a @@-separated list of regular expressions that must all
# match the combined stdout and stderr.
if(WORK_DIR)
  file(REMOVE_RECURSE "${WORK_DIR}")
  file(MAKE_DIRECTORY "${WORK_DIR}")
endif()
execute_process(COMMAND ${COMMAND}
  RESULT_VARIABLE exit_code OUTPUT_VARIABLE out ERROR_VARIABLE err
  WORKING_DIRECTORY "${WORK_DIR}")
set(all "${out}${err}")
message("${all}")
if(NOT "${exit_code}" STREQUAL "${EXPECT_EXIT}")
  message(FATAL_ERROR "exit code ${exit_code}, expected ${EXPECT_EXIT}")
endif()
string(REPLACE "@@" ";" regexes "${EXPECT_REGEX}")
foreach(regex IN LISTS regexes)
  if(NOT all MATCHES "${regex}")
    message(FATAL_ERROR "output does not match '${regex}'")
  endif()
endforeach()
