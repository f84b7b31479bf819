// ROS 2 bags (MCAP, sqlite3, bag folders) as a BagSource: the storage through
// ros2_bag.h, the messages through ros2_cdr.h into the ROS 1 structs.
#include <algorithm>
#include <utility>

#include "bag_source.h"
#include "lookboth/core/error.h"
#include "ros2_bag.h"
#include "ros2_cdr.h"

namespace lookboth::bag {

namespace fs = std::filesystem;

namespace {

class Ros2Message final : public BagMessage {
 public:
  explicit Ros2Message(const ros2::Message& message) : message_(message) {}

  const std::string& topic() const override { return message_.topic->name; }
  TimeNs receiveTime() const override { return message_.log_time; }
  sensor_msgs::Image image() const override { return decode(ros2::decodeImage); }
  sensor_msgs::CompressedImage compressedImage() const override {
    return decode(ros2::decodeCompressedImage);
  }
  sensor_msgs::CameraInfo cameraInfo() const override { return decode(ros2::decodeCameraInfo); }
  nav_msgs::Odometry odometry() const override { return decode(ros2::decodeOdometry); }
  geometry_msgs::PoseStamped poseStamped() const override {
    return decode(ros2::decodePoseStamped);
  }
  geometry_msgs::PoseWithCovarianceStamped poseWithCovarianceStamped() const override {
    return decode(ros2::decodePoseWithCovarianceStamped);
  }
  std::vector<geometry_msgs::TransformStamped> transforms() const override {
    return decode(ros2::decodeTfMessage);
  }

 private:
  template <typename Decode>
  auto decode(Decode&& decoder) const -> decltype(decoder(std::declval<ros2::Cdr>())) {
    const std::string& format = message_.topic->serialization_format;
    if (format != "cdr") {
      throw Problem("the message is serialized as '" + format +
                    "'; lookboth reads CDR (the ROS 2 default)");
    }
    try {
      return decoder(message_.data);
    } catch (const ros2::DecodeError& e) {
      throw Problem(std::string("the message is corrupt (") + message_.where + "): " + e.what());
    }
  }

  const ros2::Message& message_;
};

class Ros2BagSource final : public BagSource {
 public:
  explicit Ros2BagSource(const fs::path& path)
      : reader_(ros2::BagReader::open(path)), format_(formatOf(path)) {}

  std::string formatName() const override { return "ROS 2 bag (" + format_ + ")"; }
  bool ros2() const override { return true; }

  std::map<std::string, std::set<std::string>> topicTypes() override {
    std::map<std::string, std::set<std::string>> present;
    for (const ros2::Topic& topic : reader_->topics()) present[topic.name].insert(topic.type);
    return present;
  }

  std::int64_t count(const std::vector<std::string>& topics) override {
    return reader_->messageCount({topics.begin(), topics.end()});
  }

  std::vector<std::string> notes() const override { return reader_->notes(); }

  void forEach(const std::vector<std::string>& topics,
               const std::function<bool(const BagMessage&)>& visit) override {
    const std::set<std::string> wanted(topics.begin(), topics.end());
    reader_->rewind();
    ros2::Message message;
    while (reader_->next(wanted, &message)) {
      if (!visit(Ros2Message(message))) return;
    }
  }

 private:
  /// The storage, for messages: from the file's extension or the folder's files.
  static std::string formatOf(const fs::path& path) {
    std::error_code ec;
    if (!fs::is_directory(path, ec)) return path.extension() == ".db3" ? "sqlite3" : "MCAP";
    for (const fs::directory_entry& entry : fs::directory_iterator(path, ec)) {
      if (entry.path().extension() == ".db3") return "sqlite3";
      if (entry.path().extension() == ".mcap") return "MCAP";
    }
    return "folder";
  }

  std::unique_ptr<ros2::BagReader> reader_;
  std::string format_;
};

}  // namespace

bool looksLikeRos2Bag(const fs::path& path) {
  std::error_code ec;
  const std::string extension = path.extension().string();
  return fs::is_directory(path, ec) || extension == ".mcap" || extension == ".db3" ||
         path.filename() == "metadata.yaml";
}

std::unique_ptr<BagSource> openRos2Bag(const fs::path& path) {
  return std::make_unique<Ros2BagSource>(path);
}

}  // namespace lookboth::bag
