#include <gtest/gtest.h>
#include <mrpt/io/CFileGZInputStream.h>
#include <mrpt/io/CFileGZOutputStream.h>
#include <mrpt/obs/CObservation6DFeatures.h>
#include <mrpt/obs/CObservationImage.h>
#include <mrpt/obs/CRawlog.h>
#include <mrpt/serialization/CArchive.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>
#include <opencv2/core.hpp>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <set>

#include "lookboth/core/atomic_file.h"
#include "lookboth/core/error.h"
#include "lookboth/geometry/pose_conversions.h"
#include "lookboth/obs/CObservationMarkerCorners.h"
#include "test_dataset.h"

namespace lookboth {
namespace {

namespace fs = std::filesystem;

class RawlogIoTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("lookboth_rawlog_" +
            std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    rawlog_ = dir_ / "sample.rawlog";
  }
  void TearDown() override { fs::remove_all(dir_); }

  void writeSample(const std::vector<Record>& records, const fs::path& path) {
    auto writer = DatasetWriter::create(path, DatasetKind::kRawlog, testing::sampleManifest());
    for (const Record& r : records) writer->write(r);
    writer->finish();
  }

  std::vector<Record> readAll(const fs::path& path, const DatasetReadOptions& options = {}) {
    auto reader = DatasetReader::open(path, options);
    std::vector<Record> records;
    while (auto r = reader->next()) records.push_back(*r);
    issues_ = reader->issues();
    return records;
  }

  std::vector<std::string> entries() const {
    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(dir_))
      names.push_back(e.path().filename().string());
    std::sort(names.begin(), names.end());
    return names;
  }

  fs::path dir_, rawlog_;
  std::vector<DatasetIssue> issues_;
};

// The uncompressed bytes of a gzip rawlog, and back.
std::string gunzip(const fs::path& path) {
  mrpt::io::CFileGZInputStream in(path.string());
  std::string bytes;
  char buffer[65536];
  size_t n;
  while ((n = in.Read(buffer, sizeof(buffer))) > 0) bytes.append(buffer, n);
  return bytes;
}
void gzip(const fs::path& path, const std::string& bytes) {
  mrpt::io::CFileGZOutputStream out(path.string());
  out.Write(bytes.data(), bytes.size());
}

TEST_F(RawlogIoTest, RoundTripLosesNothing) {
  const auto records = testing::sampleRecords();
  writeSample(records, rawlog_);
  EXPECT_EQ(entries(), (std::vector<std::string>{"sample.rawlog", "sample.yaml", "sample_Images"}));
  const auto back = readAll(rawlog_);
  ASSERT_EQ(back.size(), records.size());
  for (size_t i = 0; i < records.size(); ++i)
    EXPECT_TRUE(testing::sameRecord(records[i], back[i])) << i;
  EXPECT_TRUE(issues_.empty());
  const Manifest manifest = loadManifest(dir_ / "sample.yaml");
  EXPECT_EQ(manifest.rawlog_entries, static_cast<std::int64_t>(records.size()));
  EXPECT_EQ(manifest.name, "sample");
  // Opening through the manifest path works too.
  EXPECT_EQ(readAll(dir_ / "sample.yaml").size(), records.size());
}

size_t countCorners(const std::vector<Record>& records) {
  size_t n = 0;
  for (const Record& r : records) {
    const auto* m = std::get_if<MarkerObservation>(&r);
    n += m && !m->corners_px.empty();
  }
  return n;
}

TEST_F(RawlogIoTest, MarkerCornersRoundTripExactlyAndOldRawlogsReadWithout) {
  const auto records = testing::withCorners(testing::sampleRecords());
  const size_t with_corners = countCorners(records);
  ASSERT_EQ(with_corners, 5u);
  writeSample(records, rawlog_);
  const auto back = readAll(rawlog_);
  ASSERT_EQ(back.size(), records.size());
  for (size_t i = 0; i < records.size(); ++i)
    EXPECT_TRUE(testing::sameRecord(records[i], back[i])) << i;
  EXPECT_TRUE(issues_.empty());
  EXPECT_EQ(countCorners(back), with_corners);
  // One more rawlog entry per marker with corners, which MRPT reads too.
  EXPECT_EQ(loadManifest(dir_ / "sample.yaml").rawlog_entries,
            static_cast<std::int64_t>(records.size() + with_corners));
  mrpt::obs::CRawlog rawlog;
  ASSERT_TRUE(rawlog.loadFromRawLogFile(rawlog_.string()));
  EXPECT_EQ(rawlog.size(), records.size() + with_corners);
  // A rawlog without corners (written before they existed) reads as before.
  fs::remove_all(dir_);
  fs::create_directories(dir_);
  writeSample(testing::sampleRecords(), rawlog_);
  const auto old = readAll(rawlog_);
  EXPECT_EQ(old.size(), records.size());
  EXPECT_EQ(countCorners(old), 0u);
  EXPECT_TRUE(issues_.empty());
}

TEST_F(RawlogIoTest, WriterRefusesAMarkerWithoutFourCorners) {
  auto records = testing::sampleRecords();
  auto writer = DatasetWriter::create(rawlog_, DatasetKind::kRawlog, testing::sampleManifest());
  MarkerObservation marker = std::get<MarkerObservation>(records[3]);
  marker.corners_px.resize(3);
  try {
    writer->write(marker);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("has 3 corners (expected 0 or 4)"), std::string::npos)
        << e.what();
  }
}

// Corners pair with the pose of the entry just before; a repeated pose is
// dropped with its corners; corners that match no pose are reported.
TEST_F(RawlogIoTest, CornersPairOnlyWithTheirPose) {
  writeSample({}, rawlog_);
  const TimeNs t = secondsToNs(1700000000);
  auto features = [&](TimeNs stamp, int id) {
    mrpt::obs::CObservation6DFeatures obs;
    obs.sensorLabel = "cam00";
    obs.timestamp = toMrptTime(stamp);
    mrpt::obs::CObservation6DFeatures::TMeasurement m;
    m.pose = mrpt::poses::CPose3D(0.1, 0.2, 3.0, 0, 0, 0);
    m.id = id;
    m.inf_matrix.setIdentity();
    obs.sensedFeatures.push_back(m);
    return obs;
  };
  auto corners = [&](TimeNs stamp, int id, double u0) {
    CObservationMarkerCorners obs;
    obs.sensorLabel = "cam00";
    obs.timestamp = toMrptTime(stamp);
    obs.marker_id = id;
    obs.corners = {{{u0, 10}, {u0 + 20, 10}, {u0 + 20, 30}, {u0, 30}}};
    obs.corner_sigma_px = 0.25;
    return obs;
  };
  {
    mrpt::io::CFileGZOutputStream file(rawlog_.string());
    auto out = mrpt::serialization::archiveFrom(file);
    out << features(t, 7) << corners(t, 7, 100);  // 1, 2: a pair
    out << features(t, 7) << corners(t, 7, 200);  // 3, 4: repeated stamp: both dropped
    out << features(t + 1000, 7);                 // 5: a pose without corners
    out << corners(t + 1000, 8, 300);             // 6: another marker id: no pose for it
    out << corners(t + 5000, 7, 400);             // 7: no pose before
  }
  const auto back = readAll(rawlog_);
  ASSERT_EQ(back.size(), 2u);
  const auto& first = std::get<MarkerObservation>(back[0]);
  ASSERT_EQ(first.corners_px.size(), 4u);
  EXPECT_EQ(first.corners_px[1], Eigen::Vector2d(120, 10));
  EXPECT_EQ(first.corner_sigma_px, 0.25);
  EXPECT_TRUE(std::get<MarkerObservation>(back[1]).corners_px.empty());
  ASSERT_EQ(issues_.size(), 3u);
  EXPECT_NE(issues_[0].message.find("repeats timestamp"), std::string::npos);
  EXPECT_NE(issues_[1].where.find("entry 6"), std::string::npos) << issues_[1].where;
  EXPECT_NE(issues_[1].message.find("(marker 8)"), std::string::npos) << issues_[1].message;
  EXPECT_NE(issues_[1].message.find("do not follow their marker pose"), std::string::npos);
  EXPECT_NE(issues_[2].where.find("entry 7"), std::string::npos) << issues_[2].where;
}

TEST_F(RawlogIoTest, MrptReadsOurRawlogAndFindsTheImages) {
  writeSample(testing::sampleRecords(), rawlog_);
  mrpt::obs::CRawlog rawlog;
  ASSERT_TRUE(rawlog.loadFromRawLogFile(rawlog_.string()));
  EXPECT_EQ(rawlog.size(), testing::sampleRecords().size());
  mrpt::img::CImage::setImagesPathBase(imagesDirectoryFor(rawlog_).string());
  for (size_t i = 0; i < rawlog.size(); ++i) {
    if (auto image =
            std::dynamic_pointer_cast<mrpt::obs::CObservationImage>(rawlog.getAsObservation(i))) {
      EXPECT_EQ(image->image.getWidth(), 32u);  // loads the external file
      EXPECT_EQ(image->image.getHeight(), 24u);
    }
  }
}

TEST_F(RawlogIoTest, RefusesToOverwriteUnlessAskedAndCleansUpWhenAbandoned) {
  writeSample(testing::sampleRecords(), rawlog_);
  const auto before = entries();
  EXPECT_THROW(DatasetWriter::create(rawlog_, DatasetKind::kRawlog, testing::sampleManifest()),
               Error);
  {
    DatasetWriteOptions overwrite;
    overwrite.overwrite = true;
    auto writer =
        DatasetWriter::create(rawlog_, DatasetKind::kRawlog, testing::sampleManifest(), overwrite);
    for (const Record& r : testing::sampleRecords()) writer->write(r);
    // destroyed without finish(): an interruption
  }
  EXPECT_EQ(entries(), before);  // no temporary left, the old dataset intact
  EXPECT_EQ(readAll(rawlog_).size(), testing::sampleRecords().size());
  DatasetWriteOptions overwrite;
  overwrite.overwrite = true;
  auto writer =
      DatasetWriter::create(rawlog_, DatasetKind::kRawlog, testing::sampleManifest(), overwrite);
  writer->write(testing::sampleRecords().front());  // a pose: the new dataset has no images
  writer->finish();
  EXPECT_EQ(readAll(rawlog_).size(), 1u);
  EXPECT_EQ(entries(),
            (std::vector<std::string>{"sample.rawlog", "sample.yaml"}));  // stale images removed
}

TEST_F(RawlogIoTest, TruncationInsideAnEntryIsAnErrorAfterTheGoodEntries) {
  writeSample(testing::sampleRecords(), rawlog_);
  const std::string bytes = gunzip(rawlog_);
  gzip(rawlog_, bytes.substr(0, bytes.size() * 2 / 3));
  auto reader = DatasetReader::open(rawlog_);
  size_t delivered = 0;
  try {
    while (reader->next()) ++delivered;
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("sample.rawlog: entry"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("truncated"), std::string::npos) << e.what();
  }
  EXPECT_GT(delivered, 20u);  // everything before the cut was delivered
}

TEST_F(RawlogIoTest, TruncationAtAnEntryBoundaryIsCaughtByTheManifestCount) {
  writeSample(testing::sampleRecords(), rawlog_);
  Manifest manifest = loadManifest(dir_ / "sample.yaml");
  manifest.rawlog_entries += 1;
  saveManifest(manifest, dir_ / "sample.yaml");
  try {
    readAll(rawlog_);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("truncated: 50 of the 51 entries"), std::string::npos)
        << e.what();
  }
}

TEST_F(RawlogIoTest, UnregisteredClassNamesTheEntry) {
  writeSample(testing::sampleRecords(), rawlog_);
  std::string bytes = gunzip(rawlog_);
  const std::string name = "lookboth::CObservationBlobs";
  const size_t at = bytes.find(name);
  ASSERT_NE(at, std::string::npos);
  bytes.replace(at, name.size(), "lookboth::CObservationBlobz");
  gzip(rawlog_, bytes);
  try {
    readAll(rawlog_);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    // The fifth entry (the first blobs), 1-based as in the issues.
    EXPECT_NE(std::string(e.what()).find("entry 5 (byte "), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("not registered"), std::string::npos) << e.what();
    EXPECT_EQ(std::string(e.what()).find("===="), std::string::npos) << e.what();
  }
}

// MRPT's exception text is a banner, "Message: <cause>", a location and a
// call stack: the error carries the cause, and names the entry and offset.
TEST_F(RawlogIoTest, ReadErrorsCarryMrptsCauseAndTheEntry) {
  writeSample(testing::sampleRecords(), rawlog_);
  const std::string original = gunzip(rawlog_);
  auto errorOf = [&](const std::string& bytes) -> std::string {
    gzip(rawlog_, bytes);
    try {
      readAll(rawlog_);
    } catch (const Error& e) {
      return e.what();
    } catch (const std::exception& e) {
      return std::string("not a lookboth::Error: ") + e.what();
    }
    return "(no error)";
  };
  // The class name's length byte of the third entry (the first image): 127.
  std::string bytes = original;
  const std::string image_class = "mrpt::obs::CObservationImage";
  const size_t image = bytes.find(image_class);
  ASSERT_NE(image, std::string::npos);
  bytes[image - 1] = static_cast<char>(0xFF);
  std::string message = errorOf(bytes);
  EXPECT_NE(message.find("sample.rawlog: entry 3 (byte " + std::to_string(image - 1)),
            std::string::npos)
      << message;
  EXPECT_NE(message.find("Class name has more than 120 chars"), std::string::npos) << message;
  EXPECT_EQ(message.find("===="), std::string::npos) << message;
  EXPECT_EQ(message.find("Call stack"), std::string::npos) << message;

  // The version of the fifth entry (the first blobs): 99.
  bytes = original;
  const std::string blobs_class = "lookboth::CObservationBlobs";
  const size_t blobs = bytes.find(blobs_class);
  ASSERT_NE(blobs, std::string::npos);
  bytes[blobs + blobs_class.size()] = 99;
  message = errorOf(bytes);
  EXPECT_NE(message.find("entry 5 (byte " + std::to_string(blobs - 1) +
                         ", lookboth::CObservationBlobs v99)"),
            std::string::npos)
      << message;
  EXPECT_NE(message.find("unknown serialization version number: '99'"), std::string::npos)
      << message;
  EXPECT_EQ(message.find("===="), std::string::npos) << message;
}

// MRPT writes an empty pointer as a marker of its own; reading one gives no
// object (found by fuzz_rawlog: a member call on it). It is skipped, said once.
TEST_F(RawlogIoTest, AnEmptyObjectIsSkippedWithANote) {
  writeSample({}, rawlog_);
  {
    mrpt::io::CFileGZOutputStream file(rawlog_.string());
    auto out = mrpt::serialization::archiveFrom(file);
    mrpt::obs::CObservation6DFeatures features;
    features.sensorLabel = "cam00";
    features.timestamp = toMrptTime(1'000'000'000);
    out.WriteObject(nullptr);
    out << features;
  }
  readAll(rawlog_);
  bool said = false;
  for (const DatasetIssue& issue : issues_)
    said = said || issue.message.find("empty (null) objects") != std::string::npos;
  EXPECT_TRUE(said);
}

// A colour image that another MRPT program embedded in its rawlog is a JPEG,
// which MRPT decodes while reading the entry with libjpeg's default error
// handler: that one would print and exit(1), ending the program without a
// word about the file. jpeg_errors.cpp makes it an error of the entry.
TEST_F(RawlogIoTest, ACorruptEmbeddedJpegIsAnErrorOfItsEntry) {
  writeSample({}, rawlog_);
  cv::Mat colour(48, 64, CV_8UC3);
  cv::randu(colour, cv::Scalar::all(0), cv::Scalar::all(255));
  {
    // MRPT's own default is raw pixels; its programs may choose JPEG.
    const bool raw = mrpt::img::CImage::DISABLE_JPEG_COMPRESSION();
    mrpt::img::CImage::DISABLE_JPEG_COMPRESSION(false);
    mrpt::io::CFileGZOutputStream file(rawlog_.string());
    auto out = mrpt::serialization::archiveFrom(file);
    for (int i = 0; i < 2; ++i) {
      mrpt::obs::CObservationImage obs;
      obs.sensorLabel = "cam00";
      obs.timestamp = toMrptTime(1'000'000'000LL * (i + 1));
      obs.image = mrpt::img::CImage(colour, mrpt::img::DEEP_COPY);
      out << obs;
    }
    mrpt::img::CImage::DISABLE_JPEG_COMPRESSION(raw);
  }
  const size_t intact = readAll(rawlog_).size();
  EXPECT_EQ(intact, 2u) << "both images read while intact";

  // The second image's JPEG: its frame header (SOF0, FF C0) says 3 bits a
  // sample, which libjpeg refuses.
  std::string bytes = gunzip(rawlog_);
  const size_t second = bytes.find("\xFF\xD8\xFF", bytes.find("\xFF\xD8\xFF") + 3);
  ASSERT_NE(second, std::string::npos) << "MRPT embeds colour images as JPEG";
  const size_t frame = bytes.find("\xFF\xC0", second);
  ASSERT_NE(frame, std::string::npos);
  bytes[frame + 4] = 3;
  gzip(rawlog_, bytes);
  std::string message = "(no error)";
  try {
    readAll(rawlog_);
  } catch (const Error& e) {
    message = e.what();
  }
  EXPECT_NE(message.find("sample.rawlog: entry 2"), std::string::npos) << message;
  EXPECT_NE(message.find("corrupt JPEG image (libjpeg: Unsupported JPEG data precision 3)"),
            std::string::npos)
      << message;
}

// A string length of MRPT's serialization set to 0xFFFFFFFF: the reader
// must say so at once, not allocate 4 GB first. Read in a child whose
// address space is capped, so that an unbounded allocation fails there (and
// the error differs) instead of taking the memory of the test machine.
#if defined(__SANITIZE_ADDRESS__)
#define LOOKBOTH_TEST_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define LOOKBOTH_TEST_ASAN 1
#endif
#endif

TEST_F(RawlogIoTest, ACorruptLengthIsAnErrorWithoutAllocatingIt) {
#ifdef LOOKBOTH_TEST_ASAN
  GTEST_SKIP() << "AddressSanitizer's operator new replaces the reader's bounded one, and its "
                  "shadow memory rules out an address-space cap";
#endif
  writeSample(testing::sampleRecords(), rawlog_);
  std::string bytes = gunzip(rawlog_);
  const std::string label("\x05\0\0\0cam00", 9);  // the first "cam00" string
  const size_t at = bytes.find(label);
  ASSERT_NE(at, std::string::npos);
  bytes.replace(at, 4, std::string(4, '\xFF'));
  gzip(rawlog_, bytes);

  int pipe_fds[2];
  ASSERT_EQ(::pipe(pipe_fds), 0);
  const auto start = std::chrono::steady_clock::now();
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    ::close(pipe_fds[0]);
    // Room for what the process maps already plus 1 GiB: not for 4 GB.
    std::ifstream statm("/proc/self/statm");
    std::uint64_t pages = 0;
    statm >> pages;
    const rlim_t cap = pages * static_cast<rlim_t>(::sysconf(_SC_PAGESIZE)) + (rlim_t{1} << 30);
    const rlimit limit{cap, cap};
    ::setrlimit(RLIMIT_AS, &limit);
    std::string message = "(no error)";
    int code = 3;
    try {
      auto reader = DatasetReader::open(rawlog_);
      while (reader->next()) {
      }
    } catch (const Error& e) {
      message = e.what();
      code = 0;
    } catch (const std::exception& e) {
      message = std::string("not a lookboth::Error: ") + e.what();
      code = 2;
    }
    const ssize_t written = ::write(pipe_fds[1], message.data(), message.size());
    ::_exit(written < 0 ? 4 : code);
  }
  ::close(pipe_fds[1]);
  std::string message;
  char buffer[4096];
  for (ssize_t n; (n = ::read(pipe_fds[0], buffer, sizeof buffer)) > 0;) message.append(buffer, n);
  ::close(pipe_fds[0]);
  int status = 0;
  rusage usage{};
  ASSERT_EQ(::wait4(child, &status, 0, &usage), child);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  ASSERT_TRUE(WIFEXITED(status)) << "the reader died: " << message;
  EXPECT_EQ(WEXITSTATUS(status), 0) << message;
  EXPECT_NE(message.find("sample.rawlog: entry "), std::string::npos) << message;
  EXPECT_NE(message.find("corrupt: a length in it asks for 4294967296 bytes of memory"),
            std::string::npos)
      << message;
  EXPECT_LT(seconds, 10.0);
  EXPECT_LT(usage.ru_maxrss, 400 * 1024) << "peak resident KiB";  // Linux: KiB
  std::printf("corrupt length: %.2f s, child's peak RSS %ld KiB: %s\n", seconds, usage.ru_maxrss,
              message.c_str());
}

// Markers of two ids seen by one camera in one frame are two observations:
// folder -> rawlog -> records keeps both. The same marker twice keeps the
// detection with the smaller uncertainty, in both formats.
TEST_F(RawlogIoTest, TwoMarkersInOneFrameSurviveAFolderRawlogRoundTrip) {
  std::vector<Record> records = testing::sampleRecords();
  MarkerObservation other;
  for (const Record& r : records) {
    if (const auto* m = std::get_if<MarkerObservation>(&r)) {
      other = *m;
      break;
    }
  }
  other.marker_id = 3;  // another marker in the robot's frame, same camera and time
  other.camera_from_marker.translation.x() += 0.5;
  std::vector<Record> with_other;
  for (const Record& r : records) {
    with_other.push_back(r);
    const auto* m = std::get_if<MarkerObservation>(&r);
    if (m && m->t == other.t && m->camera == other.camera) with_other.push_back(other);
  }
  const fs::path folder = dir_ / "folder";
  {
    auto writer = DatasetWriter::create(folder, DatasetKind::kFolder, testing::sampleManifest());
    for (const Record& r : with_other) writer->write(r);
    writer->finish();
  }
  auto markersAt = [&](const std::vector<Record>& all) {
    std::set<int> ids;
    for (const Record& r : all) {
      const auto* m = std::get_if<MarkerObservation>(&r);
      if (m && m->t == other.t && m->camera == other.camera) ids.insert(m->marker_id);
    }
    return ids;
  };
  DatasetReadOptions no_image_check;  // the sample's images are smaller than its calibrations
  no_image_check.check_images = false;
  const std::vector<Record> from_folder = readAll(folder, no_image_check);
  EXPECT_TRUE(issues_.empty()) << issues_.front().message;
  EXPECT_EQ(markersAt(from_folder), (std::set<int>{3, 7}));
  writeSample(from_folder, rawlog_);
  const std::vector<Record> back = readAll(rawlog_);
  EXPECT_TRUE(issues_.empty()) << issues_.front().where << ": " << issues_.front().message;
  EXPECT_EQ(back.size(), from_folder.size());
  EXPECT_EQ(markersAt(back), (std::set<int>{3, 7}));

  // The robot's marker twice in that frame, the second detection more
  // certain: both readers keep it, and say which was dropped.
  MarkerObservation better = other;
  better.marker_id = 7;
  better.information *= 100.0;
  std::vector<Record> twice;
  for (const Record& r : with_other) {
    twice.push_back(r);
    const auto* m = std::get_if<MarkerObservation>(&r);
    if (m && m->t == other.t && m->marker_id == 3) twice.push_back(better);
  }
  const fs::path folder2 = dir_ / "folder2";
  {
    auto writer = DatasetWriter::create(folder2, DatasetKind::kFolder, testing::sampleManifest());
    for (const Record& r : twice) writer->write(r);
    writer->finish();
  }
  const fs::path rawlog2 = dir_ / "twice.rawlog";
  writeSample(twice, rawlog2);
  for (const fs::path& path : {folder2, rawlog2}) {
    const std::vector<Record> read = readAll(path, no_image_check);
    EXPECT_EQ(read.size(), with_other.size()) << path;
    ASSERT_EQ(issues_.size(), 1u) << path;
    EXPECT_NE(issues_[0].message.find("'cam00'"), std::string::npos) << issues_[0].message;
    EXPECT_NE(issues_[0].message.find("marker 7"), std::string::npos) << issues_[0].message;
    EXPECT_NE(issues_[0].message.find("smaller uncertainty"), std::string::npos)
        << issues_[0].message;
    for (const Record& r : read) {
      const auto* m = std::get_if<MarkerObservation>(&r);
      if (m && m->t == other.t && m->marker_id == 7) {
        EXPECT_EQ(m->information, better.information) << path;
        EXPECT_EQ(m->camera_from_marker.translation, better.camera_from_marker.translation);
      }
    }
  }
}

TEST_F(RawlogIoTest, DuplicateTimestampsAreDroppedWithAWarningOrRefusedWhenStrict) {
  auto records = testing::sampleRecords();
  records.insert(records.begin() + 1, records.front());  // same odometry sample twice
  writeSample(records, rawlog_);
  const auto back = readAll(rawlog_);
  EXPECT_EQ(back.size(), records.size() - 1);
  ASSERT_EQ(issues_.size(), 1u);
  EXPECT_NE(issues_[0].where.find("entry 2"), std::string::npos) << issues_[0].where;
  EXPECT_NE(issues_[0].message.find("repeats timestamp"), std::string::npos) << issues_[0].message;
  DatasetReadOptions strict;
  strict.strict = true;
  EXPECT_THROW(readAll(rawlog_, strict), Error);
}

TEST_F(RawlogIoTest, MissingImageIsReportedAndSkipped) {
  writeSample(testing::sampleRecords(), rawlog_);
  fs::path victim;
  for (const auto& e : fs::directory_iterator(imagesDirectoryFor(rawlog_))) victim = e.path();
  fs::remove(victim);
  const auto back = readAll(rawlog_);
  EXPECT_EQ(back.size(), testing::sampleRecords().size() - 1);
  ASSERT_EQ(issues_.size(), 1u);
  EXPECT_NE(issues_[0].message.find(victim.filename().string()), std::string::npos)
      << issues_[0].message;
  EXPECT_NE(issues_[0].message.find("missing"), std::string::npos);
}

TEST_F(RawlogIoTest, MissingManifestIsNamed) {
  writeSample(testing::sampleRecords(), rawlog_);
  fs::remove(dir_ / "sample.yaml");
  try {
    DatasetReader::open(rawlog_);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("sample.yaml"), std::string::npos) << e.what();
  }
}

TEST_F(RawlogIoTest, RefusesTwoFramesOfOneCameraAtOneTime) {
  auto writer = DatasetWriter::create(rawlog_, DatasetKind::kRawlog, testing::sampleManifest());
  ImageFrame frame;
  frame.t = 1000;
  frame.sensor = "cam00";
  frame.encoded = testing::pngBytes(1);
  frame.extension = ".png";
  writer->write(frame);
  try {
    writer->write(frame);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("two frames of the same camera at t=1000 ns"),
              std::string::npos)
        << e.what();
    EXPECT_NE(std::string(e.what()).find("[cam00]"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace lookboth
