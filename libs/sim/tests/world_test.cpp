// The simulated facility: determinism, ceiling heights, ray casting, shading.
#include "lookboth/sim/world.h"

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <set>

#include "lookboth/core/error.h"

namespace lookboth::sim {
namespace {

bool sameElements(const World& a, const World& b) {
  if (a.elements().size() != b.elements().size()) return false;
  for (std::size_t k = 0; k < a.elements().size(); ++k) {
    const Box& x = a.elements()[k];
    const Box& y = b.elements()[k];
    if (x.material != y.material || x.texture_seed != y.texture_seed ||
        !x.box.min().isApprox(y.box.min(), 0) || !x.box.max().isApprox(y.box.max(), 0)) {
      return false;
    }
  }
  return true;
}

TEST(WorldSpec, CheckNamesTheField) {
  EXPECT_EQ(WorldSpec{}.check(), "");
  WorldSpec spec;
  spec.ceiling_max_m = 2.0;
  EXPECT_NE(spec.check().find("ceiling_max_m"), std::string::npos);
  spec = WorldSpec{};
  spec.low_texture_region = {1, 2, 3};
  EXPECT_NE(spec.check().find("low_texture_region"), std::string::npos);
  spec.low_texture_region = {5, 2, 3, 4};
  EXPECT_NE(spec.check().find("low_texture_region"), std::string::npos);
  spec = WorldSpec{};
  spec.vents = -1;
  EXPECT_NE(spec.check().find("vents"), std::string::npos);
  EXPECT_THROW(World(spec, 1), Error);
}

TEST(World, DeterministicBySeed) {
  const WorldSpec spec;
  const World a(spec, 42), b(spec, 42), c(spec, 43);
  EXPECT_TRUE(sameElements(a, b));
  EXPECT_FALSE(sameElements(a, c));
  // Shading is a function of the seed and the point only.
  const Eigen::Vector3d origin(13.3, 7.7, 0.4);
  const Eigen::Vector3d up = Eigen::Vector3d(0.3, -0.2, 1.0).normalized();
  const Hit ha = a.intersect(origin, up), hb = b.intersect(origin, up);
  EXPECT_EQ(ha.distance, hb.distance);
  EXPECT_EQ(a.shade(ha), b.shade(hb));
}

TEST(World, HasEveryKindOfFixture) {
  const WorldSpec spec;
  const World world(spec, 7);
  std::map<Material, int> counts;
  for (const Box& b : world.elements()) ++counts[b.material];
  EXPECT_GE(counts[Material::kCeilingSlab], 4);
  EXPECT_EQ(counts[Material::kBeam], spec.beams);
  EXPECT_EQ(counts[Material::kDuct], spec.ducts);
  EXPECT_EQ(counts[Material::kCableTray], spec.cable_trays);
  EXPECT_EQ(counts[Material::kVent], spec.vents);
  // A few panels are deliberately missing, as in a real car park.
  EXPECT_GE(counts[Material::kLightPanel], spec.light_panels * 8 / 10);
  EXPECT_LE(counts[Material::kLightPanel], spec.light_panels);
  EXPECT_EQ(counts[Material::kWall], 4);
}

TEST(World, CeilingHeightsWithinBoundsAndNotFlat) {
  const WorldSpec spec;
  const World world(spec, 3);
  std::set<double> heights;
  double lo = 1e9, hi = -1e9;
  for (double x = 0.05; x < spec.length_m; x += 0.37) {
    for (double y = 0.05; y < spec.width_m; y += 0.41) {
      const double h = world.ceilingHeightAt(x, y);
      lo = std::min(lo, h);
      hi = std::max(hi, h);
      heights.insert(std::round(h * 1000.0));
    }
  }
  EXPECT_GE(lo, spec.ceiling_min_m);
  EXPECT_LE(hi, spec.ceiling_max_m);
  EXPECT_GT(hi - lo, 0.3 * (spec.ceiling_max_m - spec.ceiling_min_m));
  EXPECT_GT(heights.size(), 10u);
  // The slab undersides alone also vary and stay within bounds.
  std::set<double> slabs;
  for (const Box& b : world.elements()) {
    if (b.material != Material::kCeilingSlab) continue;
    slabs.insert(b.box.min().z());
    EXPECT_GE(b.box.min().z(), spec.ceiling_min_m);
    EXPECT_LE(b.box.min().z(), spec.ceiling_max_m);
  }
  EXPECT_GT(slabs.size(), 3u);
}

TEST(World, RaysUpHitTheCeilingAndRaysDownTheFloor) {
  const WorldSpec spec;
  const World world(spec, 11);
  int checked = 0;
  for (double x = 0.3; x < spec.length_m; x += 1.37) {
    for (double y = 0.3; y < spec.width_m; y += 1.13) {
      const Hit up = world.intersect({x, y, 0.5}, Eigen::Vector3d::UnitZ());
      ASSERT_TRUE(up.valid()) << x << " " << y;
      EXPECT_NE(up.material, Material::kFloor);
      EXPECT_NE(up.material, Material::kHousing);
      EXPECT_NEAR(up.point.z(), world.ceilingHeightAt(x, y), 1e-9) << x << " " << y;
      EXPECT_NEAR(up.distance, world.ceilingHeightAt(x, y) - 0.5, 1e-9);
      EXPECT_NEAR(up.normal.z(), -1.0, 1e-12);
      // The legacy form agrees.
      Material m;
      Eigen::Vector3d p;
      std::uint32_t seed;
      EXPECT_EQ(world.intersect({x, y, 0.5}, Eigen::Vector3d::UnitZ(), &m, &p, &seed), up.distance);
      EXPECT_EQ(m, up.material);
      EXPECT_EQ(seed, up.texture_seed);

      const Hit down = world.intersect({x, y, 0.5}, -Eigen::Vector3d::UnitZ());
      EXPECT_EQ(down.material, Material::kFloor);
      EXPECT_NEAR(down.point.z(), 0.0, 1e-12);
      EXPECT_NEAR(down.distance, 0.5, 1e-12);
      ++checked;
    }
  }
  EXPECT_GT(checked, 400);
}

TEST(World, GridTraversalAgreesWithBruteForce) {
  // Oblique rays through the accelerated intersect against testing every
  // element (and the floor) directly.
  const WorldSpec spec;
  World world(spec, 5);
  world.addHousing({"cam", {20.0, 10.0, 2.9}, 0.06, 0.1, 0.02});
  std::uint64_t state = 1234;
  const auto uniform = [&](double a, double b) {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    return a + (b - a) * static_cast<double>(state >> 11) * 0x1.0p-53;
  };
  for (int k = 0; k < 20000; ++k) {
    const Eigen::Vector3d o(uniform(0.5, 39.5), uniform(0.5, 19.5), uniform(0.1, 2.8));
    const Eigen::Vector3d d =
        Eigen::Vector3d(uniform(-1, 1), uniform(-1, 1), uniform(-0.3, 1)).normalized();
    const Hit fast = world.intersect(o, d);
    double best = d.z() < 0 ? -o.z() / d.z() : std::numeric_limits<double>::infinity();
    for (const Box& b : world.elements()) {
      double t;
      Eigen::Vector3d n;
      if (rayBoxEntry(b.box, o, d, &t, &n)) best = std::min(best, t);
    }
    if (fast.material != Material::kHousing) {
      ASSERT_NEAR(fast.distance, best, 1e-9) << k;
    } else {
      ASSERT_LE(fast.distance, best);
    }
  }
}

TEST(World, RayTowardAHousingHitsIt) {
  World world(WorldSpec{}, 9);
  const Eigen::Vector3d centre(12.0, 6.0, 2.85);
  world.addHousing({"cam07", centre, 0.06, 0.10, 0.02});
  ASSERT_EQ(world.housings().size(), 1u);
  for (const Eigen::Vector3d& from :
       {Eigen::Vector3d(12.0, 6.0, 0.3), Eigen::Vector3d(10.0, 5.0, 0.3),
        Eigen::Vector3d(14.5, 3.0, 0.3)}) {
    const Eigen::Vector3d d = (centre - from).normalized();
    const Hit hit = world.intersect(from, d);
    EXPECT_EQ(hit.material, Material::kHousing) << materialName(hit.material);
    EXPECT_EQ(hit.housing, 0);
    EXPECT_NEAR((hit.point - centre).norm(), 0.06, 1e-9);
    EXPECT_LT(world.shade(hit), 0.1);  // dark
    // A little to the side, the ray misses the dome and meets the ceiling.
    const Eigen::Vector3d aside = (centre + Eigen::Vector3d(0.0, 0.3, 0.0) - from).normalized();
    EXPECT_NE(world.intersect(from, aside).material, Material::kHousing);
  }
  // From inside its housing, a camera looks out.
  const Hit out = world.intersect(centre, -Eigen::Vector3d::UnitZ());
  EXPECT_EQ(out.material, Material::kFloor);
}

TEST(World, LowTextureRegionShadesConstant) {
  WorldSpec spec;
  spec.low_texture_region = {10.0, 0.0, 22.0, 20.0};
  const World plain(spec, 21);
  spec.low_texture_region.clear();
  const World textured(spec, 21);
  std::set<double> inside, outside, reference;
  for (double x = 10.2; x < 21.8; x += 0.173) {
    for (double y = 0.2; y < 19.8; y += 0.191) {
      const Eigen::Vector3d o(x, y, 0.3);
      inside.insert(plain.shade(plain.intersect(o, Eigen::Vector3d::UnitZ())));
      reference.insert(textured.shade(textured.intersect(o, Eigen::Vector3d::UnitZ())));
      const Eigen::Vector3d o2(x + 15.0, y, 0.3);
      outside.insert(plain.shade(plain.intersect(o2, Eigen::Vector3d::UnitZ())));
    }
  }
  EXPECT_EQ(inside.size(), 1u);
  EXPECT_GT(outside.size(), 500u);
  EXPECT_GT(reference.size(), 500u);
  EXPECT_TRUE(plain.inLowTextureRegion(15, 5));
  EXPECT_FALSE(plain.inLowTextureRegion(25, 5));
}

TEST(World, TexturesAreDeterministicAndVaried) {
  const World world(WorldSpec{}, 1);
  std::set<long> levels;
  for (double x = 0.1; x < 30.0; x += 0.0731) {
    const Hit a = world.intersect({x, 3.3, 1.0}, -Eigen::Vector3d::UnitZ());
    const double s = world.shade(a);
    EXPECT_EQ(s, world.shade(a));
    EXPECT_EQ(s, world.shade(Material::kFloor, a.point, a.texture_seed));
    EXPECT_GE(s, 0.0);
    EXPECT_LE(s, 1.0);
    levels.insert(std::lround(s * 255));
  }
  EXPECT_GT(levels.size(), 30u);
  EXPECT_GE(valueNoise(0.3, 0.7, 5), 0.0);
  EXPECT_LE(valueNoise(0.3, 0.7, 5), 1.0);
  EXPECT_EQ(valueNoise(1.25, -3.5, 9), valueNoise(1.25, -3.5, 9));
  EXPECT_NE(valueNoise(1.25, -3.5, 9), valueNoise(1.25, -3.5, 10));
}

}  // namespace
}  // namespace lookboth::sim
