# lookboth convert on a ROS 1 bag written by the rosbag C++ API (the sample of
# libs/dataset/tests/rosbag_import_test.cpp), to a rawlog, then to a folder.
file(REMOVE_RECURSE "${WORK_DIR}")
file(MAKE_DIRECTORY "${WORK_DIR}")
set(ENV{LOOKBOTH_SAMPLE_BAG} "${WORK_DIR}/sample.bag")
execute_process(COMMAND ${MAKER} --gtest_filter=RosbagSample.* RESULT_VARIABLE rc OUTPUT_QUIET)
if(NOT rc EQUAL 0 OR NOT EXISTS "${WORK_DIR}/sample.bag")
  message(FATAL_ERROR "could not write the sample bag")
endif()
execute_process(COMMAND ${LOOKBOTH} convert --from ${WORK_DIR}/sample.bag --to ${WORK_DIR}/bag.rawlog
    --topic /fisheye/image_raw=fisheye:fisheye --topic /fisheye/camera_info=fisheye:fisheye
    --topic /cam03/image/compressed=cam03:env_camera --topic /cam03/camera_info=cam03:env_camera
    --topic /odom=odometry:odometry:nonmetric --topic /ground_truth/pose=ground_truth:ground_truth
    --marker DICT_5X5_100:17:0.15
  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
message("${out}${err}")
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "bag -> rawlog failed (${rc})")
endif()
if(NOT out MATCHES "wrote .*bag.rawlog: 29 records")
  message(FATAL_ERROR "expected 29 records (5 + 4 frames, 10 + 10 poses)")
endif()
execute_process(COMMAND ${LOOKBOTH} convert --from ${WORK_DIR}/bag.rawlog --to ${WORK_DIR}/bag_folder
  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
message("${out}${err}")
if(NOT rc EQUAL 0 OR NOT out MATCHES "29 records \\(image: 9, pose: 20\\)")
  message(FATAL_ERROR "rawlog -> folder failed")
endif()
foreach(f marker.yaml fisheye/calibration.yaml cameras/cam03/calibration.yaml odometry/trajectory.tum
          ground_truth/trajectory.tum)
  if(NOT EXISTS "${WORK_DIR}/bag_folder/${f}")
    message(FATAL_ERROR "the folder lacks ${f}")
  endif()
endforeach()
