# MRPT's rawlog-edit must read a rawlog of lookboth observations when given
# our library as a plugin (-p), and must fail to without it.
file(REMOVE_RECURSE "${WORK_DIR}")
file(MAKE_DIRECTORY "${WORK_DIR}")
set(ENV{LOOKBOTH_BLOBS_RAWLOG} "${WORK_DIR}/blobs.rawlog")
execute_process(COMMAND ${MAKER} --gtest_filter=Blobs.WritesARawlogMrptReadsBack RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "could not write the test rawlog")
endif()

execute_process(COMMAND ${RAWLOG_EDIT} -p ${PLUGIN} -i ${WORK_DIR}/blobs.rawlog --info
  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
message("${out}${err}")
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "rawlog-edit with the plugin failed (${rc})")
endif()
if(NOT "${out}${err}" MATCHES "Overall number of objects *: 3")
  message(FATAL_ERROR "rawlog-edit --info with the plugin does not count the 3 observations")
endif()

# Our class's text export, driven by MRPT's tool. (rawlog-edit 2.5.8 joins the
# output folder and file name without a '/' for an absolute input path, so
# the input is given relative to the working directory.)
execute_process(COMMAND ${RAWLOG_EDIT} -p ${PLUGIN} -i blobs.rawlog --export-txt
  WORKING_DIRECTORY ${WORK_DIR} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
message("${out}${err}")
file(READ ${WORK_DIR}/blobs_fisheye.txt exported)
message("${exported}")
if(NOT exported MATCHES "U_PX V_PX DIAMETER_PX RESPONSE" OR NOT exported MATCHES "812.25 411.5 14 0.8 1203 77.125 9.5 0.25")
  message(FATAL_ERROR "rawlog-edit --export-txt did not write our blobs")
endif()

# Without the plugin MRPT cannot read the class: the checks above are not vacuous.
execute_process(COMMAND ${RAWLOG_EDIT} -i ${WORK_DIR}/blobs.rawlog --info
  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if("${out}${err}" MATCHES "Overall number of objects *: 3")
  message(FATAL_ERROR "rawlog-edit read our class without the plugin: the test proves nothing")
endif()
