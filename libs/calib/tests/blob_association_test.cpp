// The windowed association (blobs by column) against the scan of every blob.
#include "../src/blob_association.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

namespace lookboth {
namespace {

TEST(BlobAssociation, ByColumnEqualsTheScan) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(0, 1920), v(0, 1080), near(-12, 12), unit(0, 1);
  std::uniform_int_distribution<int> count(0, 60), cameras(1, 30);
  int associated = 0, refused = 0;
  for (int trial = 0; trial < 4000; ++trial) {
    // Blobs: some anywhere, some next to the cameras' projections, some on
    // a coarse grid (equal distances: ties), some duplicated.
    std::vector<std::pair<std::size_t, Eigen::Vector2d>> projected;
    const int n_cameras = cameras(rng);
    for (int c = 0; c < n_cameras; ++c) {
      const double y = v(rng);
      projected.emplace_back(static_cast<std::size_t>(c), Eigen::Vector2d(u(rng), y));
    }
    std::vector<Blob> blobs;
    const int n_blobs = count(rng);
    for (int b = 0; b < n_blobs; ++b) {
      Blob blob;
      const double kind = unit(rng);
      if (kind < 0.3) {
        blob.u = u(rng);
        blob.v = v(rng);
      } else if (kind < 0.8 || blobs.empty()) {
        const Eigen::Vector2d& p = projected[static_cast<std::size_t>(b) % projected.size()].second;
        blob.u = p.x() + near(rng);
        blob.v = p.y() + near(rng);
      } else if (kind < 0.9) {
        const Eigen::Vector2d& p = projected[static_cast<std::size_t>(b) % projected.size()].second;
        blob.u = std::round(p.x()) + 4 * std::round(near(rng) / 4);
        blob.v = std::round(p.y()) + 4 * std::round(near(rng) / 4);
      } else {
        blob = blobs[static_cast<std::size_t>(b) % blobs.size()];
      }
      blobs.push_back(blob);
    }
    // Some cameras on the grid too, so that blobs tie in distance.
    for (auto& [c, p] : projected) {
      if (unit(rng) < 0.2) p = Eigen::Vector2d(std::round(p.x()), std::round(p.y()));
    }
    calib_detail::BlobsByColumn by_column;
    by_column.assign(blobs);
    for (const double gate : {3.0, 10.0, 25.0}) {
      for (const double ratio : {1.0, 1.5, 3.0}) {
        for (const auto& [c, pixel] : projected) {
          const auto fast =
              calib_detail::associatedBlob(by_column, c, pixel, gate, ratio, projected);
          const auto scan =
              calib_detail::associatedBlobByScan(blobs, c, pixel, gate, ratio, projected);
          ASSERT_EQ(fast.has_value(), scan.has_value())
              << "trial " << trial << " camera " << c << " gate " << gate << " ratio " << ratio;
          if (fast) {
            ASSERT_EQ(*fast, *scan) << "trial " << trial << " camera " << c;
            ++associated;
          } else {
            ++refused;
          }
        }
      }
    }
  }
  // Both outcomes are exercised.
  EXPECT_GT(associated, 10000);
  EXPECT_GT(refused, 10000);
  std::printf("%d associated, %d refused\n", associated, refused);
}

}  // namespace
}  // namespace lookboth
