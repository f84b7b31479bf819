#include <gtest/gtest.h>
#include <mrpt/io/CFileGZInputStream.h>
#include <mrpt/io/CFileGZOutputStream.h>
#include <mrpt/obs/CObservationImage.h>
#include <mrpt/obs/CRawlog.h>

#include "lookboth/core/atomic_file.h"
#include "lookboth/core/error.h"
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
    EXPECT_NE(std::string(e.what()).find("entry 4"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("not registered"), std::string::npos) << e.what();
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
