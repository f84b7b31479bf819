# ROS 1 bag -> dataset import (lookboth::dataset_rosbag), included from
# libs/dataset/CMakeLists.txt. Uses Debian's rosbag_storage and message
# headers (cmake/FindRosbagStorage.cmake); no ROS installation needed.
find_package(RosbagStorage REQUIRED)
find_package(OpenCV 4 REQUIRED COMPONENTS core imgproc imgcodecs)
# The bag structure check decompresses bz2 chunks itself (lz4: roslz4, which
# Rosbag::storage links); libbz2-dev comes with librosbag-storage-dev.
find_package(BZip2 REQUIRED)

lookboth_add_library(dataset_rosbag
  SOURCES
    src/rosbag_import.cpp
  PUBLIC_DEPS
    lookboth::dataset lookboth::core
  PRIVATE_DEPS
    Rosbag::storage BZip2::BZip2 lookboth::cameras yaml-cpp::yaml-cpp opencv_core opencv_imgproc
    opencv_imgcodecs)

lookboth_add_test(dataset/rosbag_import
  SOURCES tests/rosbag_import_test.cpp
  DEPS lookboth::dataset_rosbag Rosbag::storage opencv_core opencv_imgcodecs)
