#include <gtest/gtest.h>
#include <mrpt/io/CMemoryStream.h>
#include <mrpt/rtti/CObject.h>
#include <mrpt/serialization/CArchive.h>

#include "lookboth/obs/CObservationBlobs.h"
#include "lookboth/obs/CObservationMarkerCorners.h"

namespace lookboth {
namespace {

CObservationMarkerCorners::Ptr makeCorners() {
  auto obs = CObservationMarkerCorners::Create();
  obs->sensorLabel = "cam07";
  obs->timestamp = mrpt::Clock::fromDouble(1700000000.125);
  obs->marker_id = 17;
  obs->corners = {{{812.25, 411.5}, {860.0625, 409.75}, {861.5, 458.0}, {0.1 + 0.2, -3.5}}};
  obs->corner_sigma_px = 0.0731;
  return obs;
}

TEST(MarkerCorners, IsRegisteredUnderTheLookbothNamespace) {
  registerLookbothObservations();
  const auto* cls = mrpt::rtti::findRegisteredClass("lookboth::CObservationMarkerCorners");
  ASSERT_NE(cls, nullptr);
  EXPECT_STREQ(makeCorners()->GetRuntimeClass()->className, "lookboth::CObservationMarkerCorners");
}

TEST(MarkerCorners, SerialisationRoundTripIsExact) {
  const auto original = makeCorners();
  mrpt::io::CMemoryStream buffer;
  auto out = mrpt::serialization::archiveFrom(buffer);
  out << *original;
  buffer.Seek(0);
  auto in = mrpt::serialization::archiveFrom(buffer);
  const auto back = std::dynamic_pointer_cast<CObservationMarkerCorners>(in.ReadObject());
  ASSERT_TRUE(back);
  EXPECT_EQ(back->sensorLabel, "cam07");
  EXPECT_EQ(back->timestamp, original->timestamp);
  EXPECT_EQ(back->marker_id, 17);
  for (size_t k = 0; k < 4; ++k) {
    EXPECT_EQ(back->corners[k].u, original->corners[k].u) << k;
    EXPECT_EQ(back->corners[k].v, original->corners[k].v) << k;
  }
  EXPECT_EQ(back->corner_sigma_px, 0.0731);
  EXPECT_EQ(back->sensorPose, original->sensorPose);
}

TEST(MarkerCorners, DescriptionAndTextExportListTheCorners) {
  const auto obs = makeCorners();
  const std::string text = obs->asString();
  EXPECT_NE(text.find("Marker id: 17"), std::string::npos) << text;
  EXPECT_NE(text.find("860.062"), std::string::npos) << text;
  EXPECT_NE(text.find("cam07"), std::string::npos) << text;
  EXPECT_EQ(obs->exportTxtDataRow(),
            "17 812.25 411.5 860.0625 409.75 861.5 458 0.30000000000000004 -3.5 0.0731");
}

}  // namespace
}  // namespace lookboth
