# Finds Debian's ROS 1 bag storage library and the message headers lookboth
# reads from bags, without a ROS installation (no catkin environment needed):
#
#   librosbag-storage-dev libroscpp-core-dev libsensor-msgs-dev libnav-msgs-dev
#   libgeometry-msgs-dev libstd-msgs-dev   (scripts/setup.sh installs them)
#
# Defines the imported target Rosbag::storage and RosbagStorage_FOUND.
#
# Debian ships catkin-style rosbag_storageConfig.cmake files, but they need
# catkin's environment, and rosbag_storage.pc requires a pluginlib.pc that
# Debian does not ship; so everything is found explicitly here. rosbag/bag.h
# includes pluginlib's (ROS 2 style) headers, which live one level down
# (/usr/include/pluginlib/pluginlib/...), as do class_loader, rcutils,
# rcpputils and ament_index_cpp: their folders are added as include dirs.
# Only headers are used from those; nothing of theirs is linked.

include(FindPackageHandleStandardArgs)

find_path(RosbagStorage_INCLUDE_DIR NAMES rosbag/bag.h)
find_path(RosbagStorage_ROSCPP_CORE_INCLUDE_DIR NAMES ros/time.h ros/serialization.h)
find_path(RosbagStorage_MSGS_INCLUDE_DIR
  NAMES sensor_msgs/Image.h sensor_msgs/CompressedImage.h sensor_msgs/CameraInfo.h)
find_path(RosbagStorage_NAV_MSGS_INCLUDE_DIR NAMES nav_msgs/Odometry.h)
find_path(RosbagStorage_GEOMETRY_MSGS_INCLUDE_DIR NAMES geometry_msgs/PoseStamped.h)
find_path(RosbagStorage_STD_MSGS_INCLUDE_DIR NAMES std_msgs/Header.h)
find_path(RosbagStorage_CONSOLE_BRIDGE_INCLUDE_DIR NAMES console_bridge/console.h)
find_path(RosbagStorage_PLUGINLIB_INCLUDE_DIR NAMES pluginlib/class_loader.hpp PATH_SUFFIXES pluginlib)
find_path(RosbagStorage_CLASS_LOADER_INCLUDE_DIR NAMES class_loader/multi_library_class_loader.hpp
  PATH_SUFFIXES class_loader)
find_path(RosbagStorage_RCUTILS_INCLUDE_DIR NAMES rcutils/logging_macros.h PATH_SUFFIXES rcutils)
find_path(RosbagStorage_RCPPUTILS_INCLUDE_DIR NAMES rcpputils/shared_library.hpp PATH_SUFFIXES rcpputils)
find_path(RosbagStorage_AMENT_INDEX_INCLUDE_DIR NAMES ament_index_cpp/get_resource.hpp
  PATH_SUFFIXES ament_index_cpp)

find_library(RosbagStorage_LIBRARY NAMES rosbag_storage)
find_library(RosbagStorage_ROSCPP_SERIALIZATION_LIBRARY NAMES roscpp_serialization)
find_library(RosbagStorage_ROSTIME_LIBRARY NAMES rostime)
find_library(RosbagStorage_CPP_COMMON_LIBRARY NAMES cpp_common)
find_library(RosbagStorage_CONSOLE_BRIDGE_LIBRARY NAMES console_bridge)
find_library(RosbagStorage_ROSLZ4_LIBRARY NAMES roslz4)

find_package(Boost QUIET COMPONENTS filesystem)

find_package_handle_standard_args(RosbagStorage
  REQUIRED_VARS
    RosbagStorage_LIBRARY RosbagStorage_INCLUDE_DIR
    RosbagStorage_ROSCPP_CORE_INCLUDE_DIR RosbagStorage_MSGS_INCLUDE_DIR
    RosbagStorage_NAV_MSGS_INCLUDE_DIR RosbagStorage_GEOMETRY_MSGS_INCLUDE_DIR
    RosbagStorage_STD_MSGS_INCLUDE_DIR RosbagStorage_CONSOLE_BRIDGE_INCLUDE_DIR
    RosbagStorage_PLUGINLIB_INCLUDE_DIR RosbagStorage_CLASS_LOADER_INCLUDE_DIR
    RosbagStorage_RCUTILS_INCLUDE_DIR RosbagStorage_RCPPUTILS_INCLUDE_DIR
    RosbagStorage_AMENT_INDEX_INCLUDE_DIR
    RosbagStorage_ROSCPP_SERIALIZATION_LIBRARY RosbagStorage_ROSTIME_LIBRARY
    RosbagStorage_CPP_COMMON_LIBRARY RosbagStorage_CONSOLE_BRIDGE_LIBRARY
    RosbagStorage_ROSLZ4_LIBRARY Boost_FOUND
  REASON_FAILURE_MESSAGE
    "install librosbag-storage-dev libroscpp-core-dev libsensor-msgs-dev libnav-msgs-dev libgeometry-msgs-dev libstd-msgs-dev (scripts/setup.sh)")

if(RosbagStorage_FOUND AND NOT TARGET Rosbag::storage)
  add_library(Rosbag::storage UNKNOWN IMPORTED)
  set(_rosbag_include_dirs
    ${RosbagStorage_INCLUDE_DIR} ${RosbagStorage_ROSCPP_CORE_INCLUDE_DIR}
    ${RosbagStorage_MSGS_INCLUDE_DIR} ${RosbagStorage_NAV_MSGS_INCLUDE_DIR}
    ${RosbagStorage_GEOMETRY_MSGS_INCLUDE_DIR} ${RosbagStorage_STD_MSGS_INCLUDE_DIR}
    ${RosbagStorage_CONSOLE_BRIDGE_INCLUDE_DIR} ${RosbagStorage_PLUGINLIB_INCLUDE_DIR}
    ${RosbagStorage_CLASS_LOADER_INCLUDE_DIR} ${RosbagStorage_RCUTILS_INCLUDE_DIR}
    ${RosbagStorage_RCPPUTILS_INCLUDE_DIR} ${RosbagStorage_AMENT_INDEX_INCLUDE_DIR})
  list(REMOVE_DUPLICATES _rosbag_include_dirs)
  # Imported targets' include dirs are SYSTEM for their users: ROS headers'
  # warnings do not count against -Werror.
  set_target_properties(Rosbag::storage PROPERTIES
    IMPORTED_LOCATION "${RosbagStorage_LIBRARY}"
    INTERFACE_INCLUDE_DIRECTORIES "${_rosbag_include_dirs}"
    INTERFACE_LINK_LIBRARIES
      "${RosbagStorage_ROSCPP_SERIALIZATION_LIBRARY};${RosbagStorage_ROSTIME_LIBRARY};${RosbagStorage_CPP_COMMON_LIBRARY};${RosbagStorage_CONSOLE_BRIDGE_LIBRARY};${RosbagStorage_ROSLZ4_LIBRARY};Boost::filesystem")
  unset(_rosbag_include_dirs)
endif()

mark_as_advanced(
  RosbagStorage_INCLUDE_DIR RosbagStorage_ROSCPP_CORE_INCLUDE_DIR RosbagStorage_MSGS_INCLUDE_DIR
  RosbagStorage_NAV_MSGS_INCLUDE_DIR RosbagStorage_GEOMETRY_MSGS_INCLUDE_DIR
  RosbagStorage_STD_MSGS_INCLUDE_DIR RosbagStorage_CONSOLE_BRIDGE_INCLUDE_DIR
  RosbagStorage_PLUGINLIB_INCLUDE_DIR RosbagStorage_CLASS_LOADER_INCLUDE_DIR
  RosbagStorage_RCUTILS_INCLUDE_DIR RosbagStorage_RCPPUTILS_INCLUDE_DIR
  RosbagStorage_AMENT_INDEX_INCLUDE_DIR RosbagStorage_LIBRARY
  RosbagStorage_ROSCPP_SERIALIZATION_LIBRARY RosbagStorage_ROSTIME_LIBRARY
  RosbagStorage_CPP_COMMON_LIBRARY RosbagStorage_CONSOLE_BRIDGE_LIBRARY RosbagStorage_ROSLZ4_LIBRARY)
