#include <gtest/gtest.h>
#include <mrpt/io/CFileGZInputStream.h>
#include <mrpt/io/CFileGZOutputStream.h>
#include <mrpt/io/CMemoryStream.h>
#include <mrpt/obs/CRawlog.h>
#include <mrpt/rtti/CObject.h>
#include <mrpt/serialization/CArchive.h>

#include <cstdlib>
#include <filesystem>

#include "lookboth/obs/CObservationBlobs.h"

namespace lookboth {
namespace {

CObservationBlobs::Ptr makeBlobs() {
  auto obs = CObservationBlobs::Create();
  obs->sensorLabel = "fisheye";
  obs->timestamp = mrpt::Clock::fromDouble(1700000000.25);
  obs->image_width = 1920;
  obs->image_height = 1080;
  obs->sensorPose = mrpt::poses::CPose3D(0.1, 0.0, 0.4, 0.0, -M_PI / 2, 0.0);
  obs->blobs = {{812.25, 411.5, 14.0, 0.8}, {1203.0, 77.125, 9.5, 0.25}};
  return obs;
}

TEST(Blobs, IsRegisteredUnderTheLookbothNamespace) {
  registerLookbothObservations();
  const auto* cls = mrpt::rtti::findRegisteredClass("lookboth::CObservationBlobs");
  ASSERT_NE(cls, nullptr);
  EXPECT_STREQ(makeBlobs()->GetRuntimeClass()->className, "lookboth::CObservationBlobs");
}

TEST(Blobs, SerialisationRoundTripIsExact) {
  const auto original = makeBlobs();
  mrpt::io::CMemoryStream buffer;
  auto out = mrpt::serialization::archiveFrom(buffer);
  out << *original;
  buffer.Seek(0);
  auto in = mrpt::serialization::archiveFrom(buffer);
  const auto object = in.ReadObject();
  const auto back = std::dynamic_pointer_cast<CObservationBlobs>(object);
  ASSERT_TRUE(back);
  EXPECT_EQ(back->sensorLabel, "fisheye");
  EXPECT_EQ(back->timestamp, original->timestamp);
  EXPECT_EQ(back->image_width, 1920);
  ASSERT_EQ(back->blobs.size(), 2u);
  EXPECT_EQ(back->blobs[1].v, 77.125);
  EXPECT_EQ(back->blobs[0].response, 0.8);
  EXPECT_EQ(back->sensorPose, original->sensorPose);
}

TEST(Blobs, DescriptionListsTheBlobs) {
  const std::string text = makeBlobs()->asString();
  EXPECT_NE(text.find("Number of blobs: 2"), std::string::npos) << text;
  EXPECT_NE(text.find("812.250"), std::string::npos) << text;
  EXPECT_NE(text.find("fisheye"), std::string::npos) << text;
}

// Writes a small observations-only rawlog (to $LOOKBOTH_BLOBS_RAWLOG when set,
// for the rawlog-edit plugin test) and reads it back with MRPT's reader.
TEST(Blobs, WritesARawlogMrptReadsBack) {
  const char* env = std::getenv("LOOKBOTH_BLOBS_RAWLOG");
  const std::filesystem::path path =
      env ? std::filesystem::path(env)
          : std::filesystem::temp_directory_path() / "lookboth_blobs_test.rawlog";
  {
    mrpt::io::CFileGZOutputStream file(path.string());
    auto out = mrpt::serialization::archiveFrom(file);
    for (int i = 0; i < 3; ++i) {
      auto obs = makeBlobs();
      obs->timestamp = mrpt::Clock::fromDouble(1700000000.0 + i / 30.0);
      out << *obs;
    }
  }
  mrpt::io::CFileGZInputStream file(path.string());
  auto in = mrpt::serialization::archiveFrom(file);
  mrpt::obs::CActionCollection::Ptr actions;
  mrpt::obs::CSensoryFrame::Ptr frame;
  mrpt::obs::CObservation::Ptr obs;
  size_t index = 0;
  int read = 0;
  while (
      mrpt::obs::CRawlog::getActionObservationPairOrObservation(in, actions, frame, obs, index)) {
    ASSERT_TRUE(std::dynamic_pointer_cast<CObservationBlobs>(obs));
    ++read;
  }
  EXPECT_EQ(read, 3);
  if (!env) std::filesystem::remove(path);
}

}  // namespace
}  // namespace lookboth
