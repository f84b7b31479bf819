#include <gtest/gtest.h>

#include <fstream>
#include <iterator>

#include "test_dataset.h"

namespace lookboth::testing {
namespace {

std::vector<std::uint8_t> bytesOf(const ImageFrame& frame) {
  if (frame.encoded) return *frame.encoded;
  std::ifstream in(frame.image_file, std::ios::binary);
  return std::vector<std::uint8_t>(std::istreambuf_iterator<char>(in), {});
}

bool samePose(const Rigid3d& a, const Rigid3d& b) {
  return (a.translation - b.translation).norm() < 1e-12 &&
         a.rotation.angularDistance(b.rotation) < 1e-9;
}

}  // namespace

::testing::AssertionResult sameRecord(const Record& a, const Record& b) {
  if (a.index() != b.index()) return ::testing::AssertionFailure() << "different kinds";
  if (recordTime(a) != recordTime(b)) {
    return ::testing::AssertionFailure() << "times " << recordTime(a) << " vs " << recordTime(b);
  }
  if (recordLabel(a) != recordLabel(b)) {
    return ::testing::AssertionFailure() << "labels " << recordLabel(a) << " vs " << recordLabel(b);
  }
  if (const auto* fa = std::get_if<ImageFrame>(&a)) {
    if (bytesOf(*fa) != bytesOf(std::get<ImageFrame>(b)))
      return ::testing::AssertionFailure() << "image bytes differ";
  } else if (const auto* ma = std::get_if<MarkerObservation>(&a)) {
    const auto& mb = std::get<MarkerObservation>(b);
    if (ma->marker_id != mb.marker_id || !samePose(ma->camera_from_marker, mb.camera_from_marker) ||
        ma->information != mb.information) {
      return ::testing::AssertionFailure() << "marker observations differ";
    }
    if (ma->corners_px != mb.corners_px || ma->corner_sigma_px != mb.corner_sigma_px) {
      return ::testing::AssertionFailure() << "marker corners differ";
    }
  } else if (const auto* ba = std::get_if<BlobObservation>(&a)) {
    const auto& bb = std::get<BlobObservation>(b);
    if (ba->blobs.size() != bb.blobs.size())
      return ::testing::AssertionFailure() << "blob counts differ";
    for (size_t i = 0; i < ba->blobs.size(); ++i) {
      if (ba->blobs[i].u != bb.blobs[i].u || ba->blobs[i].v != bb.blobs[i].v ||
          ba->blobs[i].diameter_px != bb.blobs[i].diameter_px ||
          ba->blobs[i].response != bb.blobs[i].response) {
        return ::testing::AssertionFailure() << "blob " << i << " differs";
      }
    }
  } else if (const auto* pa = std::get_if<PoseSample>(&a)) {
    if (!samePose(pa->world_from_body, std::get<PoseSample>(b).world_from_body)) {
      return ::testing::AssertionFailure() << "poses differ";
    }
  }
  return ::testing::AssertionSuccess();
}

}  // namespace lookboth::testing
