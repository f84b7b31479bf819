# ROS 1 bag -> dataset import (lookboth::dataset_rosbag), included from
# libs/dataset/CMakeLists.txt. Uses Debian's rosbag_storage and message
# headers (cmake/FindRosbagStorage.cmake); no ROS installation needed.
find_package(RosbagStorage REQUIRED)
find_package(OpenCV 4 REQUIRED COMPONENTS core imgproc imgcodecs)
# The bag structure check decompresses bz2 chunks itself (lz4: roslz4, which
# Rosbag::storage links); libbz2-dev comes with librosbag-storage-dev.
find_package(BZip2 REQUIRED)
# ROS 2 bags (src/ros2_bag.cpp, src/ros2_cdr.cpp): sqlite3 and MCAP storage
# (MCAP chunks: LZ4 frames, zstd, CRC-32 from zlib), CDR through Fast CDR.
find_package(SQLite3 REQUIRED)
find_package(ZLIB REQUIRED)
find_package(fastcdr REQUIRED)
find_package(zstd REQUIRED)
find_package(PkgConfig REQUIRED)
pkg_check_modules(LZ4 REQUIRED IMPORTED_TARGET liblz4)

lookboth_add_library(dataset_rosbag
  SOURCES
    src/rosbag_import.cpp
    src/ros1_bag_source.cpp
    src/ros2_bag_source.cpp
    src/ros2_bag.cpp
    src/ros2_cdr.cpp
  PUBLIC_DEPS
    lookboth::dataset lookboth::core
  PRIVATE_DEPS
    Rosbag::storage BZip2::BZip2 lookboth::cameras yaml-cpp::yaml-cpp opencv_core opencv_imgproc
    opencv_imgcodecs SQLite::SQLite3 ZLIB::ZLIB fastcdr zstd::libzstd_shared PkgConfig::LZ4)

lookboth_add_test(dataset/rosbag_import
  SOURCES tests/rosbag_import_test.cpp
  DEPS lookboth::dataset_rosbag Rosbag::storage opencv_core opencv_imgcodecs)

lookboth_add_test(dataset/ros2_bag
  SOURCES tests/ros2_bag_test.cpp
  DEPS lookboth::dataset_rosbag Rosbag::storage SQLite::SQLite3 nlohmann_json::nlohmann_json)

lookboth_add_test(dataset/ros2_import
  SOURCES tests/ros2_import_test.cpp
  DEPS lookboth::dataset_rosbag opencv_core opencv_imgcodecs nlohmann_json::nlohmann_json)
