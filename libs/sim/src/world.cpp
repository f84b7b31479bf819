// The procedural facility: layout, ray casting and textures (world.h).
#include "lookboth/sim/world.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "lookboth/core/error.h"
#include "lookboth/core/text.h"

namespace lookboth::sim {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
/// Hits closer than this are ignored (self-intersection guard) [m].
constexpr double kMinDistance = 1e-6;
/// Wall thickness and how far slabs reach above ceiling_max [m].
constexpr double kWallThickness = 0.4;
constexpr double kSlabThickness = 0.3;
/// Grey level of the whole ceiling inside the low-texture region.
constexpr double kLowTextureGrey = 0.55;

// ---------------------------------------------------------------- randomness

/// SplitMix64: a tiny, well-mixed generator with a fixed algorithm (unlike
/// std:: distributions, whose output differs between standard libraries).
class SplitMix64 {
 public:
  explicit SplitMix64(std::uint64_t state) : state_(state) {}
  std::uint64_t next() {
    std::uint64_t z = (state_ += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  /// Uniform in [a, b).
  double uniform(double a, double b) {
    return a + (b - a) * static_cast<double>(next() >> 11) * 0x1.0p-53;
  }

 private:
  std::uint64_t state_;
};

std::uint64_t mix64(std::uint64_t z) {
  z = (z ^ (z >> 33)) * 0xFF51AFD7ED558CCDull;
  z = (z ^ (z >> 33)) * 0xC4CEB9FE1A85EC53ull;
  return z ^ (z >> 33);
}

/// Hash of a lattice cell and a seed -> [0, 1): one multiply-xorshift
/// round over the combined coordinates (cheap; textures need no more).
double hashUnit(std::int64_t i, std::int64_t j, std::uint32_t seed) {
  std::uint64_t h =
      static_cast<std::uint64_t>(i) * 0x9E3779B97F4A7C15ull ^
      static_cast<std::uint64_t>(j) * 0xC2B2AE3D27D4EB4Full ^
      (static_cast<std::uint64_t>(seed) + 0x165667B19E3779F9ull) * 0xD6E8FEB86659FD93ull;
  h ^= h >> 32;
  h *= 0xD6E8FEB86659FD93ull;
  h ^= h >> 32;
  return static_cast<double>(h >> 11) * 0x1.0p-53;
}

std::uint32_t hash32(std::uint32_t a, std::uint32_t b) {
  return static_cast<std::uint32_t>(mix64((static_cast<std::uint64_t>(a) << 32) | b) >> 32);
}

double smoothstep(double t) { return t * t * (3.0 - 2.0 * t); }

/// Fractal sum of value noise, in [0, 1].
double fbm(double x, double y, std::uint32_t seed, int octaves) {
  double sum = 0.0, amplitude = 1.0, norm = 0.0, frequency = 1.0;
  for (int o = 0; o < octaves; ++o) {
    sum += amplitude *
           valueNoise(x * frequency, y * frequency, seed + 101u * static_cast<std::uint32_t>(o));
    norm += amplitude;
    amplitude *= 0.5;
    frequency *= 2.03;
  }
  return sum / norm;
}

/// Position of x in a periodic lattice of the given period: cell index and
/// the offset inside the cell, in [0, period).
void periodic(double x, double period, std::int64_t* cell, double* offset) {
  const double c = std::floor(x / period);
  *cell = static_cast<std::int64_t>(c);
  *offset = x - c * period;
}

/// True when x is within half_width of a multiple of period.
bool nearLattice(double x, double period, double half_width) {
  const double r = x - period * std::floor(x / period);
  return r < half_width || period - r < half_width;
}

bool isCeilingMaterial(Material m) {
  switch (m) {
    case Material::kCeilingSlab:
    case Material::kBeam:
    case Material::kDuct:
    case Material::kLightPanel:
    case Material::kCableTray:
    case Material::kVent:
      return true;
    default:
      return false;
  }
}

/// Texture coordinates on a face with the given normal: the two world axes
/// in the face's plane.
void faceCoordinates(const Eigen::Vector3d& p, const Eigen::Vector3d& n, double* u, double* v) {
  const Eigen::Vector3d a = n.cwiseAbs();
  if (a.z() >= a.x() && a.z() >= a.y()) {
    *u = p.x();
    *v = p.y();
  } else if (a.x() >= a.y()) {
    *u = p.y();
    *v = p.z();
  } else {
    *u = p.x();
    *v = p.z();
  }
}

/// Splits [0, total] into pieces of about `size`, jittered.
std::vector<double> jitteredSplits(double total, double size, SplitMix64& rng) {
  const int n = std::max(1, static_cast<int>(std::lround(total / size)));
  const double step = total / n;
  std::vector<double> cuts{0.0};
  for (int k = 1; k < n; ++k) cuts.push_back(k * step + rng.uniform(-0.25, 0.25) * step);
  cuts.push_back(total);
  return cuts;
}

// ---------------------------------------------------------------- ray vs primitives

/// Entering hit of a ray with an axis-aligned box (slab method); false when
/// the ray misses or starts inside. Fills distance and outward normal.
bool rayBox(const Eigen::AlignedBox3d& box, const Eigen::Vector3d& o, const Eigen::Vector3d& d,
            double* t_hit, Eigen::Vector3d* normal) {
  double t_near = -kInf, t_far = kInf;
  int axis = -1;
  for (int k = 0; k < 3; ++k) {
    if (d[k] == 0.0) {
      if (o[k] < box.min()[k] || o[k] > box.max()[k]) return false;
      continue;
    }
    const double inv = 1.0 / d[k];
    double t0 = (box.min()[k] - o[k]) * inv;
    double t1 = (box.max()[k] - o[k]) * inv;
    if (t0 > t1) std::swap(t0, t1);
    if (t0 > t_near) {
      t_near = t0;
      axis = k;
    }
    t_far = std::min(t_far, t1);
    if (t_near > t_far) return false;
  }
  if (axis < 0 || !(t_near > kMinDistance)) return false;
  *t_hit = t_near;
  *normal = Eigen::Vector3d::Zero();
  (*normal)[axis] = d[axis] > 0.0 ? -1.0 : 1.0;
  return true;
}

/// The same with a precomputed inverse direction (components of the
/// direction that are 0 have inverse +-1e300, so products stay finite) and
/// an upper bound on the distance; fills the axis of the face hit.
inline bool rayBoxFast(const Eigen::AlignedBox3d& box, const Eigen::Vector3d& o,
                       const Eigen::Vector3d& inv, double t_max, double* t_hit, int* axis) {
  double t_near = -kInf, t_far = t_max;
  int a = -1;
  for (int k = 0; k < 3; ++k) {
    double t0 = (box.min()[k] - o[k]) * inv[k];
    double t1 = (box.max()[k] - o[k]) * inv[k];
    if (t0 > t1) std::swap(t0, t1);
    if (t0 > t_near) {
      t_near = t0;
      a = k;
    }
    if (t1 < t_far) t_far = t1;
  }
  if (!(t_near <= t_far) || !(t_near > kMinDistance) || a < 0) return false;
  *t_hit = t_near;
  *axis = a;
  return true;
}

Eigen::Vector3d inverseDirection(const Eigen::Vector3d& d) {
  Eigen::Vector3d inv;
  for (int k = 0; k < 3; ++k) inv[k] = d[k] != 0.0 ? 1.0 / d[k] : std::copysign(1e300, d[k]);
  return inv;
}

/// Entering hit of a ray with a sphere; false when it misses or starts inside.
bool raySphere(const Eigen::Vector3d& c, double r, const Eigen::Vector3d& o,
               const Eigen::Vector3d& d, double* t_hit) {
  const Eigen::Vector3d oc = o - c;
  const double b = oc.dot(d);
  const double cc = oc.squaredNorm() - r * r;
  if (cc <= 0.0) return false;  // inside
  const double disc = b * b - cc;
  if (disc < 0.0) return false;
  const double t = -b - std::sqrt(disc);
  if (!(t > kMinDistance)) return false;
  *t_hit = t;
  return true;
}

/// Entering hit of a ray with the side of a vertical cylinder (axis through
/// (cx, cy), z in [z0, z1]); caps are not needed (the bottom is inside the
/// dome, the top inside the ceiling).
bool rayCylinder(const Eigen::Vector3d& c, double r, double z0, double z1, const Eigen::Vector3d& o,
                 const Eigen::Vector3d& d, double* t_hit, Eigen::Vector3d* normal) {
  const double ox = o.x() - c.x(), oy = o.y() - c.y();
  const double a = d.x() * d.x() + d.y() * d.y();
  if (a < 1e-18) return false;
  const double b = ox * d.x() + oy * d.y();
  const double cc = ox * ox + oy * oy - r * r;
  if (cc <= 0.0) return false;  // inside the infinite cylinder
  const double disc = b * b - a * cc;
  if (disc < 0.0) return false;
  const double t = (-b - std::sqrt(disc)) / a;
  if (!(t > kMinDistance)) return false;
  const double z = o.z() + t * d.z();
  if (z < z0 || z > z1) return false;
  *t_hit = t;
  *normal = Eigen::Vector3d(ox + t * d.x(), oy + t * d.y(), 0.0) / r;
  return true;
}

// ---------------------------------------------------------------- textures

double floorAlbedo(const WorldSpec& spec, double x, double y, std::uint32_t seed) {
  // Concrete: broad mottling, fine grain, oil stains, saw-cut joints.
  double c = 0.42 + 0.12 * (fbm(x / 2.0, y / 2.0, seed + 11u, 3) - 0.5) +
             0.10 * (valueNoise(x / 0.045, y / 0.045, seed + 12u) - 0.5) +
             0.06 * (valueNoise(x / 0.013, y / 0.013, seed + 13u) - 0.5);
  const double stain = fbm(x / 0.9, y / 0.9, seed + 14u, 3);
  if (stain > 0.66) c *= 1.0 - std::min(0.35, 4.0 * (stain - 0.66));
  if (nearLattice(x, 6.0, 0.004) || nearLattice(y, 6.0, 0.004)) c *= 0.45;
  // Paint: parking bays along both long walls, a dashed centre line.
  const double W = spec.width_m;
  const double bay_depth = std::min(5.0, 0.3 * W);
  const double wear = 0.75 + 0.25 * valueNoise(x / 0.07, y / 0.07, seed + 15u);
  bool paint = false;
  if (W >= 8.0) {
    const bool in_bays = (y > 0.25 && y < bay_depth) || (y > W - bay_depth && y < W - 0.25);
    if (in_bays && nearLattice(x, 2.5, 0.05)) paint = true;
    if (std::abs(y - bay_depth) < 0.05 || std::abs(y - (W - bay_depth)) < 0.05) paint = true;
  }
  if (std::abs(y - 0.5 * W) < 0.06 && std::fmod(std::abs(x), 6.0) < 3.0) paint = true;
  if (paint) c = 0.82 * wear;
  return c;
}

/// Board-formed concrete: plywood panel imprints (seams, per-panel shade),
/// tie holes on a regular grid (the repetition of a real ceiling), stains.
double concreteCeiling(double u, double v, std::uint32_t seed) {
  const double pw = 1.22, ph = 2.44;
  const double ou = 0.37 * hashUnit(1, 7, seed) * pw, ov = 0.53 * hashUnit(2, 9, seed) * ph;
  std::int64_t i, j;
  double fu, fv;
  periodic(u + ou, pw, &i, &fu);
  periodic(v + ov, ph, &j, &fv);
  double c = 0.62 + 0.10 * (hashUnit(i, j, seed) - 0.5);
  c *= 0.85 + 0.3 * fbm(u / 1.7, v / 1.7, seed + 1u, 2);
  c += 0.05 * (valueNoise(u / 0.03, v / 0.03, seed + 2u) - 0.5);
  if (fu < 0.008 || fv < 0.008) c *= 0.55;
  // Tie holes: 2 x 3 per panel.
  for (double hu : {0.30, 0.92}) {
    for (double hv : {0.42, 1.22, 2.02}) {
      const double du = fu - hu, dv = fv - hv;
      if (du * du + dv * dv < 0.018 * 0.018) c *= 0.3;
    }
  }
  return c;
}

/// Suspended acoustic tiles 0.6 m on a bright T-bar grid, fissured, a few
/// stained or missing.
double acousticTiles(double u, double v, std::uint32_t seed) {
  const double s = 0.6;
  std::int64_t i, j;
  double fu, fv;
  periodic(u, s, &i, &fu);
  periodic(v, s, &j, &fv);
  if (fu < 0.012 || s - fu < 0.012 || fv < 0.012 || s - fv < 0.012) return 0.85;
  const double tile = hashUnit(i, j, seed + 5u);
  if (tile < 0.03) return 0.12;  // a missing tile: the dark void above
  double c = 0.74 + 0.06 * (hashUnit(j, i, seed + 6u) - 0.5);
  const double fissure = valueNoise(u / 0.012, v / 0.012, seed + 7u);
  if (fissure > 0.72) c -= 0.2;
  c += 0.04 * (valueNoise(u / 0.05, v / 0.05, seed + 8u) - 0.5);
  const double stain = fbm(u / 2.2, v / 2.2, seed + 9u, 2);
  if (stain > 0.64) c *= 0.72;
  return c;
}

}  // namespace

// ---------------------------------------------------------------- public helpers

const char* materialName(Material material) {
  switch (material) {
    case Material::kNone:
      return "none";
    case Material::kFloor:
      return "floor";
    case Material::kCeilingSlab:
      return "ceiling_slab";
    case Material::kBeam:
      return "beam";
    case Material::kDuct:
      return "duct";
    case Material::kLightPanel:
      return "light_panel";
    case Material::kCableTray:
      return "cable_tray";
    case Material::kVent:
      return "vent";
    case Material::kHousing:
      return "housing";
    case Material::kRobotBody:
      return "robot_body";
    case Material::kMarker:
      return "marker";
    case Material::kWall:
      return "wall";
  }
  return "unknown";
}

bool rayBoxEntry(const Eigen::AlignedBox3d& box, const Eigen::Vector3d& origin,
                 const Eigen::Vector3d& direction, double* distance, Eigen::Vector3d* normal) {
  return rayBox(box, origin, direction, distance, normal);
}

double valueNoise(double x, double y, std::uint32_t seed) {
  const double fx = std::floor(x), fy = std::floor(y);
  const auto i = static_cast<std::int64_t>(fx), j = static_cast<std::int64_t>(fy);
  const double tx = smoothstep(x - fx), ty = smoothstep(y - fy);
  const double a = hashUnit(i, j, seed), b = hashUnit(i + 1, j, seed);
  const double c = hashUnit(i, j + 1, seed), d = hashUnit(i + 1, j + 1, seed);
  return (a + (b - a) * tx) + ((c + (d - c) * tx) - (a + (b - a) * tx)) * ty;
}

std::string WorldSpec::check() const {
  const auto bad = [](const std::string& field, const std::string& what, double value) {
    return "'" + field + "': " + what + ", got " + formatDouble(value);
  };
  if (!(length_m >= 2.0 && length_m <= 10000.0))
    return bad("length_m", "must be in [2, 10000]", length_m);
  if (!(width_m >= 2.0 && width_m <= 10000.0))
    return bad("width_m", "must be in [2, 10000]", width_m);
  if (!(ceiling_min_m >= 1.0 && ceiling_min_m <= 50.0)) {
    return bad("ceiling_min_m", "must be in [1, 50]", ceiling_min_m);
  }
  if (!(ceiling_max_m >= ceiling_min_m && ceiling_max_m <= 50.0)) {
    return bad("ceiling_max_m", "must be in [ceiling_min_m, 50]", ceiling_max_m);
  }
  if (!(slab_size_m >= 1.0)) return bad("slab_size_m", "must be at least 1", slab_size_m);
  const auto count = [&](const char* field, int value) -> std::string {
    if (value < 0 || value > 100000) return bad(field, "must be in [0, 100000]", value);
    return "";
  };
  for (const auto& [field, value] : {std::pair<const char*, int>{"beams", beams},
                                     {"ducts", ducts},
                                     {"light_panels", light_panels},
                                     {"cable_trays", cable_trays},
                                     {"vents", vents}}) {
    const std::string message = count(field, value);
    if (!message.empty()) return message;
  }
  if (!low_texture_region.empty()) {
    if (low_texture_region.size() != 4) {
      return "'low_texture_region': expected 4 numbers (x0, y0, x1, y1) or none, got " +
             std::to_string(low_texture_region.size());
    }
    for (double value : low_texture_region) {
      if (!std::isfinite(value)) return bad("low_texture_region", "must be finite", value);
    }
    if (!(low_texture_region[0] < low_texture_region[2] &&
          low_texture_region[1] < low_texture_region[3])) {
      return "'low_texture_region': expected x0 < x1 and y0 < y1";
    }
  }
  return "";
}

// ---------------------------------------------------------------- construction

World::World(const WorldSpec& spec, std::uint32_t seed) : spec_(spec), seed_(seed) {
  const std::string message = spec.check();
  if (!message.empty()) throw Error(ErrorContext{"", 0, "world", ""}, message);
  SplitMix64 rng(mix64(0x5EEDull ^ (static_cast<std::uint64_t>(seed) << 17)));
  const double L = spec.length_m, W = spec.width_m;
  const double lo = spec.ceiling_min_m, hi = spec.ceiling_max_m, band = hi - lo;
  const double top = hi + kSlabThickness;
  const auto add = [&](const Eigen::Vector3d& a, const Eigen::Vector3d& b, Material m) {
    const auto index = static_cast<std::uint32_t>(elements_.size());
    elements_.push_back(
        Box{Eigen::AlignedBox3d(a.cwiseMin(b), a.cwiseMax(b)), m,
            hash32(seed * 2654435761u + 17u, index * 7919u + static_cast<std::uint32_t>(m))});
  };

  // Slabs: a jittered grid, each cell with its own underside height.
  const std::vector<double> xs = jitteredSplits(L, spec.slab_size_m, rng);
  const std::vector<double> ys = jitteredSplits(W, spec.slab_size_m, rng);
  const std::size_t slab_begin = elements_.size();
  for (std::size_t i = 0; i + 1 < xs.size(); ++i) {
    for (std::size_t j = 0; j + 1 < ys.size(); ++j) {
      const double h = rng.uniform(lo + 0.45 * band, hi);
      add({xs[i], ys[j], h}, {xs[i + 1], ys[j + 1], top}, Material::kCeilingSlab);
    }
  }
  const std::size_t slab_end = elements_.size();
  // Lowest underside of the elements in [begin, end) overlapping a footprint.
  const auto lowestUnder = [&](double x0, double y0, double x1, double y1, std::size_t begin,
                               std::size_t end) {
    double z = kInf;
    for (std::size_t k = begin; k < end; ++k) {
      const Eigen::AlignedBox3d& b = elements_[k].box;
      if (b.min().x() < x1 && b.max().x() > x0 && b.min().y() < y1 && b.max().y() > y0) {
        z = std::min(z, b.min().z());
      }
    }
    return std::isfinite(z) ? z : hi;
  };

  // Beams across the width, snapped to slab joints when one is near.
  for (int k = 0; k < spec.beams; ++k) {
    double x = (k + 1) * L / (spec.beams + 1);
    for (std::size_t i = 1; i + 1 < xs.size(); ++i) {
      if (std::abs(xs[i] - x) < 1.0) x = xs[i];
    }
    const double half = rng.uniform(0.15, 0.22);
    const double under =
        std::max(lo + 0.15 * band, lowestUnder(x - half, 0.0, x + half, W, slab_begin, slab_end) -
                                       rng.uniform(0.35, 0.5));
    add({x - half, 0.0, under}, {x + half, W, top}, Material::kBeam);
  }
  const std::size_t structure_end = elements_.size();

  // Ducts along the length (partial runs), hanging lowest.
  struct Run {
    double y0, y1, x0, x1, under;
  };
  std::vector<Run> ducts;
  for (int k = 0; k < spec.ducts; ++k) {
    const double lane = W / (spec.ducts + 1);
    const double y = (k + 1) * lane + rng.uniform(-0.15, 0.15) * lane;
    const double half = 0.5 * rng.uniform(0.5, 0.9);
    const double height = rng.uniform(0.3, 0.45);
    const double under = rng.uniform(lo + 0.03, lo + 0.03 + 0.12 * band);
    const double x0 = rng.uniform(0.3, 0.3 * L), x1 = rng.uniform(0.7 * L, L - 0.3);
    ducts.push_back({y - half, y + half, x0, x1, under});
    add({x0, y - half, under}, {x1, y + half, under + height}, Material::kDuct);
  }
  // Cable trays along the length, away from the ducts.
  for (int k = 0; k < spec.cable_trays; ++k) {
    const double half = 0.5 * rng.uniform(0.3, 0.5);
    double y = rng.uniform(0.6, W - 0.6);
    for (int attempt = 0; attempt < 20; ++attempt) {
      bool clear = true;
      for (const Run& d : ducts) clear = clear && (y + half < d.y0 - 0.2 || y - half > d.y1 + 0.2);
      if (clear) break;
      y = rng.uniform(0.6, W - 0.6);
    }
    const double under = rng.uniform(lo + 0.12 * band, lo + 0.3 * band);
    const double x0 = rng.uniform(0.3, 0.2 * L), x1 = rng.uniform(0.8 * L, L - 0.3);
    add({x0, y - half, under}, {x1, y + half, under + 0.07}, Material::kCableTray);
  }
  // Light panels in regular rows (the repetition of a real car park), on the
  // slab or beam above them; a few are missing.
  if (spec.light_panels > 0) {
    const int rows =
        std::max(1, static_cast<int>(std::lround(std::sqrt(spec.light_panels * W / L))));
    const int per_row = (spec.light_panels + rows - 1) / rows;
    const bool across = hashUnit(3, 3, seed) < 0.5;
    const double hx = across ? 0.15 : 0.6, hy = across ? 0.6 : 0.15;
    int placed = 0;
    for (int r = 0; r < rows && placed < spec.light_panels; ++r) {
      for (int c = 0; c < per_row && placed < spec.light_panels; ++c, ++placed) {
        if (rng.uniform(0.0, 1.0) < 0.06) continue;  // missing
        const double x = (c + 0.5) * L / per_row + rng.uniform(-0.05, 0.05);
        const double y = (r + 0.5) * W / rows + rng.uniform(-0.05, 0.05);
        const double above = lowestUnder(x - hx, y - hy, x + hx, y + hy, slab_begin, structure_end);
        add({x - hx, y - hy, std::max(lo, above - 0.07)}, {x + hx, y + hy, above + 0.01},
            Material::kLightPanel);
      }
    }
  }
  // Vents: grilles on the ducts' undersides and on the slabs.
  const int on_ducts = ducts.empty() ? 0 : (spec.vents + 1) / 2;
  for (int k = 0; k < on_ducts; ++k) {
    const Run& d = ducts[static_cast<std::size_t>(k) % ducts.size()];
    const int per =
        (on_ducts + static_cast<int>(ducts.size()) - 1) / static_cast<int>(ducts.size());
    const int slot = k / static_cast<int>(ducts.size());
    const double x = d.x0 + (slot + 0.5) * (d.x1 - d.x0) / per;
    const double yc = 0.5 * (d.y0 + d.y1), hy = std::min(0.15, 0.5 * (d.y1 - d.y0) - 0.05);
    add({x - 0.2, yc - hy, d.under - 0.025}, {x + 0.2, yc + hy, d.under + 0.005}, Material::kVent);
  }
  for (int k = on_ducts; k < spec.vents; ++k) {
    const double x = rng.uniform(0.6, L - 0.6), y = rng.uniform(0.6, W - 0.6);
    const double above =
        lowestUnder(x - 0.25, y - 0.25, x + 0.25, y + 0.25, slab_begin, structure_end);
    add({x - 0.25, y - 0.25, std::max(lo, above - 0.03)}, {x + 0.25, y + 0.25, above + 0.01},
        Material::kVent);
  }
  // Perimeter walls.
  const double t = kWallThickness;
  for (int k = 0; k < 4; ++k) walls_[k] = static_cast<int>(elements_.size()) + k;
  wall_top_ = top;
  add({-t, -t, 0.0}, {0.0, W + t, top}, Material::kWall);
  add({L, -t, 0.0}, {L + t, W + t, top}, Material::kWall);
  add({0.0, -t, 0.0}, {L, 0.0, top}, Material::kWall);
  add({0.0, W, 0.0}, {L, W + t, top}, Material::kWall);

  buildGrid();

  // Illumination by the light panels: soft pools on a dimmer background.
  std::vector<Eigen::Vector2d> lights;
  for (const Box& b : elements_) {
    if (b.material == Material::kLightPanel) lights.emplace_back(b.box.center().head<2>());
  }
  light_cell_ = 0.5;
  light_x0_ = grid_.x0;
  light_y0_ = grid_.y0;
  light_nx_ = static_cast<int>(std::ceil(grid_.nx * grid_.cell / light_cell_)) + 1;
  light_ny_ = static_cast<int>(std::ceil(grid_.ny * grid_.cell / light_cell_)) + 1;
  light_map_.assign(static_cast<std::size_t>(light_nx_) * light_ny_, 0.0f);
  constexpr double kSigma = 2.2;
  for (int j = 0; j < light_ny_; ++j) {
    for (int i = 0; i < light_nx_; ++i) {
      const Eigen::Vector2d p(light_x0_ + i * light_cell_, light_y0_ + j * light_cell_);
      double sum = 0.0;
      for (const Eigen::Vector2d& l : lights)
        sum += std::exp(-(p - l).squaredNorm() / (2 * kSigma * kSigma));
      light_map_[static_cast<std::size_t>(j) * light_nx_ + i] =
          static_cast<float>(std::min(1.0, 0.55 + 0.45 * sum));
    }
  }
}

void World::addHousing(const Housing& housing) {
  housings_.push_back(housing);
  buildGrid();
}

void World::buildGrid() {
  // Footprints (x0, y0, x1, y1) and vertical extents of every primitive.
  struct Extent {
    double x0, y0, x1, y1, z0, z1;
  };
  // The walls reach the floor: they are tested for every ray (there are
  // four) so that the grid's vertical band starts at the ceiling's fixtures.
  std::vector<Extent> extents;
  std::vector<bool> indexed;
  for (const Box& b : elements_) {
    extents.push_back({b.box.min().x(), b.box.min().y(), b.box.max().x(), b.box.max().y(),
                       b.box.min().z(), b.box.max().z()});
    indexed.push_back(b.material != Material::kWall);
  }
  for (const Housing& h : housings_) {
    const Eigen::Vector3d& c = h.centre_in_world;
    const double r = h.radius_m;
    extents.push_back({c.x() - r, c.y() - r, c.x() + r, c.y() + r, c.z() - r,
                       c.z() + std::max(r, h.mount_radius_m > 0.0 ? h.height_m : 0.0)});
    indexed.push_back(true);
  }
  double x0 = kInf, y0 = kInf, x1 = -kInf, y1 = -kInf;
  for (const Extent& e : extents) {
    x0 = std::min(x0, e.x0);
    y0 = std::min(y0, e.y0);
    x1 = std::max(x1, e.x1);
    y1 = std::max(y1, e.y1);
  }
  Grid& g = grid_;
  g = Grid{};
  g.cell = 0.5;
  g.zlo_all = kInf;
  g.zhi_all = -kInf;
  for (std::size_t id = 0; id < extents.size(); ++id) {
    if (!indexed[id]) {
      g.always.push_back(static_cast<std::uint32_t>(id));
      continue;
    }
    g.zlo_all = std::min(g.zlo_all, extents[id].z0);
    g.zhi_all = std::max(g.zhi_all, extents[id].z1);
  }
  // Keep the grid to at most ~1M cells for huge facilities.
  while ((x1 - x0) / g.cell * (y1 - y0) / g.cell > 1.0e6) g.cell *= 2.0;
  g.x0 = x0 - 1e-6;
  g.y0 = y0 - 1e-6;
  g.nx = std::max(1, static_cast<int>(std::ceil((x1 - g.x0) / g.cell + 1e-9)));
  g.ny = std::max(1, static_cast<int>(std::ceil((y1 - g.y0) / g.cell + 1e-9)));
  const std::size_t cells = static_cast<std::size_t>(g.nx) * g.ny;
  std::vector<std::vector<std::uint32_t>> lists(cells);
  g.zlo.assign(cells, std::numeric_limits<float>::infinity());
  g.zhi.assign(cells, -std::numeric_limits<float>::infinity());
  const auto cellOf = [&](double v, double origin, int n) {
    return std::clamp(static_cast<int>(std::floor((v - origin) / g.cell)), 0, n - 1);
  };
  for (std::size_t id = 0; id < extents.size(); ++id) {
    if (!indexed[id]) continue;
    const Extent& e = extents[id];
    const int i0 = cellOf(e.x0, g.x0, g.nx), i1 = cellOf(e.x1, g.x0, g.nx);
    const int j0 = cellOf(e.y0, g.y0, g.ny), j1 = cellOf(e.y1, g.y0, g.ny);
    for (int j = j0; j <= j1; ++j) {
      for (int i = i0; i <= i1; ++i) {
        const std::size_t c = static_cast<std::size_t>(j) * g.nx + i;
        lists[c].push_back(static_cast<std::uint32_t>(id));
        // Rounded outwards so the float bounds never cut a primitive.
        g.zlo[c] = std::min(g.zlo[c], std::nextafter(static_cast<float>(e.z0), -1e9f));
        g.zhi[c] = std::max(g.zhi[c], std::nextafter(static_cast<float>(e.z1), 1e9f));
      }
    }
  }
  g.start.assign(cells + 1, 0);
  for (std::size_t c = 0; c < cells; ++c) {
    g.start[c + 1] = g.start[c] + static_cast<std::uint32_t>(lists[c].size());
  }
  g.items.reserve(g.start[cells]);
  for (const auto& list : lists) g.items.insert(g.items.end(), list.begin(), list.end());
}

// ---------------------------------------------------------------- queries

double World::ceilingHeightAt(double x, double y) const {
  const Grid& g = grid_;
  const int i = static_cast<int>(std::floor((x - g.x0) / g.cell));
  const int j = static_cast<int>(std::floor((y - g.y0) / g.cell));
  if (i < 0 || j < 0 || i >= g.nx || j >= g.ny) return spec_.ceiling_max_m;
  double z = kInf;
  const std::size_t c = static_cast<std::size_t>(j) * g.nx + i;
  for (std::uint32_t k = g.start[c]; k < g.start[c + 1]; ++k) {
    const std::uint32_t id = g.items[k];
    if (id >= elements_.size()) continue;  // a housing
    const Box& b = elements_[id];
    if (b.material == Material::kWall) continue;
    if (x >= b.box.min().x() && x <= b.box.max().x() && y >= b.box.min().y() &&
        y <= b.box.max().y()) {
      z = std::min(z, b.box.min().z());
    }
  }
  return std::isfinite(z) ? z : spec_.ceiling_max_m;
}

bool World::inLowTextureRegion(double x, double y) const {
  const std::vector<double>& r = spec_.low_texture_region;
  return r.size() == 4 && x >= r[0] && x <= r[2] && y >= r[1] && y <= r[3];
}

double World::illumination(double x, double y) const {
  const double fx = std::clamp((x - light_x0_) / light_cell_, 0.0, light_nx_ - 1.0);
  const double fy = std::clamp((y - light_y0_) / light_cell_, 0.0, light_ny_ - 1.0);
  const int i = std::min(static_cast<int>(fx), light_nx_ - 2 < 0 ? 0 : light_nx_ - 2);
  const int j = std::min(static_cast<int>(fy), light_ny_ - 2 < 0 ? 0 : light_ny_ - 2);
  const double tx = fx - i, ty = fy - j;
  const auto at = [&](int a, int b) {
    a = std::min(a, light_nx_ - 1);
    b = std::min(b, light_ny_ - 1);
    return static_cast<double>(light_map_[static_cast<std::size_t>(b) * light_nx_ + a]);
  };
  return (1 - ty) * ((1 - tx) * at(i, j) + tx * at(i + 1, j)) +
         ty * ((1 - tx) * at(i, j + 1) + tx * at(i + 1, j + 1));
}

bool World::hitPrimitive(std::uint32_t id, const Eigen::Vector3d& o, const Eigen::Vector3d& d,
                         const Eigen::Vector3d& inv, Hit* best) const {
  double t = kInf;
  if (id < elements_.size()) {
    const Box& b = elements_[id];
    int axis;
    if (!rayBoxFast(b.box, o, inv, best->distance, &t, &axis) || t >= best->distance) return false;
    best->distance = t;
    best->material = b.material;
    best->normal = Eigen::Vector3d::Zero();
    best->normal[axis] = d[axis] > 0.0 ? -1.0 : 1.0;
    best->texture_seed = b.texture_seed;
    best->element = static_cast<int>(id);
    best->housing = -1;
    return true;
  }
  Eigen::Vector3d normal;
  const auto h_index = static_cast<int>(id - elements_.size());
  const Housing& h = housings_[static_cast<std::size_t>(h_index)];
  bool hit = false;
  if (raySphere(h.centre_in_world, h.radius_m, o, d, &t) && t < best->distance) {
    best->distance = t;
    best->normal = (o + t * d - h.centre_in_world) / h.radius_m;
    hit = true;
  }
  if (h.mount_radius_m > 0.0 && h.height_m > 0.0 &&
      rayCylinder(h.centre_in_world, h.mount_radius_m, h.centre_in_world.z(),
                  h.centre_in_world.z() + h.height_m, o, d, &t, &normal) &&
      t < best->distance) {
    best->distance = t;
    best->normal = normal;
    hit = true;
  }
  if (hit) {
    best->material = Material::kHousing;
    best->texture_seed = hash32(seed_, 0x40000000u + static_cast<std::uint32_t>(h_index));
    best->element = -1;
    best->housing = h_index;
  }
  return hit;
}

void World::hitWalls(const Eigen::Vector3d& o, const Eigen::Vector3d& d, const Eigen::Vector3d& inv,
                     Hit* best) const {
  if (walls_[0] < 0) return;
  const double L = spec_.length_m, W = spec_.width_m;
  if (o.x() > 0.0 && o.x() < L && o.y() > 0.0 && o.y() < W && o.z() >= 0.0 && o.z() <= wall_top_) {
    // From inside: where the ray leaves the interior rectangle.
    double t = kInf;
    int wall = -1, axis = 0;
    if (d.x() != 0.0) {
      t = ((d.x() > 0.0 ? L : 0.0) - o.x()) * inv.x();
      wall = d.x() > 0.0 ? 1 : 0;
    }
    if (d.y() != 0.0) {
      const double ty = ((d.y() > 0.0 ? W : 0.0) - o.y()) * inv.y();
      if (ty < t) {
        t = ty;
        wall = d.y() > 0.0 ? 3 : 2;
        axis = 1;
      }
    }
    if (wall < 0 || !(t < best->distance)) return;
    const double z = o.z() + t * d.z();
    if (z < 0.0 || z > wall_top_) return;
    const Box& b = elements_[static_cast<std::size_t>(walls_[wall])];
    best->distance = t;
    best->material = b.material;
    best->normal = Eigen::Vector3d::Zero();
    best->normal[axis] = d[axis] > 0.0 ? -1.0 : 1.0;
    best->texture_seed = b.texture_seed;
    best->element = walls_[wall];
    best->housing = -1;
    return;
  }
  for (int wall : walls_) hitPrimitive(static_cast<std::uint32_t>(wall), o, d, inv, best);
}

Hit World::intersect(const Eigen::Vector3d& o, const Eigen::Vector3d& d) const {
  Hit best;
  // The floor, an infinite plane z = 0 seen from above.
  if (d.z() < 0.0 && o.z() > 0.0) {
    best.distance = -o.z() / d.z();
    best.material = Material::kFloor;
    best.normal = Eigen::Vector3d::UnitZ();
    best.texture_seed = seed_;
  }
  const Grid& g = grid_;
  const Eigen::Vector3d inv = inverseDirection(d);
  hitWalls(o, d, inv, &best);
  for (std::uint32_t id : g.always) {
    if (elements_[id].material != Material::kWall) hitPrimitive(id, o, d, inv, &best);
  }
  if (g.nx > 0 && g.zlo_all <= g.zhi_all) {
    // Clip the ray to the vertical band of the indexed primitives...
    double t0 = 0.0, t1 = best.distance;
    if (d.z() != 0.0) {
      double a = (g.zlo_all - o.z()) / d.z(), b = (g.zhi_all - o.z()) / d.z();
      if (a > b) std::swap(a, b);
      t0 = std::max(t0, a);
      t1 = std::min(t1, b);
    } else if (o.z() < g.zlo_all || o.z() > g.zhi_all) {
      t1 = -1.0;
    }
    // ... and its footprint to the grid rectangle.
    const double gx1 = g.x0 + g.nx * g.cell, gy1 = g.y0 + g.ny * g.cell;
    const double lo[2] = {g.x0, g.y0}, hi[2] = {gx1, gy1};
    bool inside = true;
    for (int k = 0; k < 2 && inside; ++k) {
      if (d[k] == 0.0) {
        inside = o[k] >= lo[k] && o[k] < hi[k];
        continue;
      }
      double a = (lo[k] - o[k]) / d[k], b = (hi[k] - o[k]) / d[k];
      if (a > b) std::swap(a, b);
      t0 = std::max(t0, a);
      t1 = std::min(t1, b);
    }
    if (inside && t0 < t1 && t0 < best.distance) {
      // 2-D DDA over the cells the footprint crosses.
      const Eigen::Vector3d p = o + t0 * d;
      int i = std::clamp(static_cast<int>(std::floor((p.x() - g.x0) / g.cell)), 0, g.nx - 1);
      int j = std::clamp(static_cast<int>(std::floor((p.y() - g.y0) / g.cell)), 0, g.ny - 1);
      const int si = d.x() > 0 ? 1 : -1, sj = d.y() > 0 ? 1 : -1;
      const double dti = d.x() != 0.0 ? g.cell / std::abs(d.x()) : kInf;
      const double dtj = d.y() != 0.0 ? g.cell / std::abs(d.y()) : kInf;
      double ti = d.x() != 0.0 ? (g.x0 + (i + (si > 0 ? 1 : 0)) * g.cell - o.x()) / d.x() : kInf;
      double tj = d.y() != 0.0 ? (g.y0 + (j + (sj > 0 ? 1 : 0)) * g.cell - o.y()) / d.y() : kInf;
      double t_enter = t0;
      for (;;) {
        const double t_exit = std::min({ti, tj, t1, best.distance});
        // Vertical extent of the ray inside this cell.
        const double za = o.z() + t_enter * d.z();
        const double zb = std::isfinite(t_exit) ? o.z() + t_exit * d.z()
                                                : (d.z() > 0 ? kInf : (d.z() < 0 ? -kInf : o.z()));
        const std::size_t c = static_cast<std::size_t>(j) * g.nx + i;
        if (std::max(za, zb) >= g.zlo[c] && std::min(za, zb) <= g.zhi[c]) {
          for (std::uint32_t k = g.start[c]; k < g.start[c + 1]; ++k)
            hitPrimitive(g.items[k], o, d, inv, &best);
        }
        if (best.distance <= std::min({ti, tj}) || t_exit >= t1) break;
        if (ti < tj) {
          i += si;
          t_enter = ti;
          ti += dti;
          if (i < 0 || i >= g.nx) break;
        } else {
          j += sj;
          t_enter = tj;
          tj += dtj;
          if (j < 0 || j >= g.ny) break;
        }
        if (t_enter >= best.distance) break;
      }
    }
  }
  if (best.valid()) best.point = o + best.distance * d;
  return best;
}

double World::intersect(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                        Material* material, Eigen::Vector3d* point,
                        std::uint32_t* texture_seed) const {
  const Hit hit = intersect(origin, direction);
  if (material) *material = hit.material;
  if (point) *point = hit.point;
  if (texture_seed) *texture_seed = hit.texture_seed;
  return hit.distance;
}

// ---------------------------------------------------------------- shading

double World::albedo(const Hit& hit) const {
  const Eigen::Vector3d& p = hit.point;
  const std::uint32_t s = hit.texture_seed;
  double u, v;
  faceCoordinates(p, hit.normal, &u, &v);
  const bool underside = hit.normal.z() < -0.5;
  switch (hit.material) {
    case Material::kNone:
      return 0.0;
    case Material::kFloor:
      return floorAlbedo(spec_, p.x(), p.y(), seed_);
    case Material::kCeilingSlab:
      if (!underside) return 0.5 + 0.15 * (fbm(u / 1.3, v / 0.7, s + 3u, 3) - 0.5);
      return (s & 1u) ? acousticTiles(u, v, s) : concreteCeiling(u, v, s);
    case Material::kBeam: {
      // Concrete with board marks along the beam (along y).
      const double base = underside ? 0.56 : 0.46;
      double c = base * (0.85 + 0.3 * fbm(u / 1.1, v / 1.1, s + 4u, 3)) +
                 0.05 * (valueNoise(u / 0.03, v / 0.03, s + 5u) - 0.5);
      if (nearLattice(p.y() + 0.3 * hashUnit(0, 1, s), 1.22, 0.006)) c *= 0.6;
      return c;
    }
    case Material::kDuct: {
      // Galvanised sheet: seams every 1.5 m, cross-break diagonals, sheen bands.
      double c = underside ? 0.68 : 0.5;
      std::int64_t section;
      double f;
      periodic(p.x() + 0.7 * hashUnit(0, 2, s), 1.5, &section, &f);
      if (f < 0.018) return 0.3;
      if (underside && hit.element >= 0) {
        const Eigen::AlignedBox3d& b = elements_[static_cast<std::size_t>(hit.element)].box;
        const double w = b.max().y() - b.min().y();
        const double fy = (p.y() - b.min().y()) / w;
        c += 0.08 * std::cos(6.0 * fy + 0.4 * static_cast<double>(section));
        const double diag1 = std::abs(fy - f / 1.5), diag2 = std::abs(1.0 - fy - f / 1.5);
        if (diag1 * w < 0.006 || diag2 * w < 0.006) c *= 0.8;
      }
      c += 0.03 * (valueNoise(u / 0.2, v / 0.2, s + 6u) - 0.5);
      return c;
    }
    case Material::kCableTray: {
      if (!underside) return 0.3;
      if (nearLattice(p.x(), 0.3, 0.012)) return 0.5;  // rungs
      std::int64_t strand;
      double f;
      periodic(p.y(), 0.018, &strand, &f);
      return 0.08 + 0.22 * hashUnit(strand, 3, s) * (f > 0.003 ? 1.0 : 0.5);
    }
    case Material::kLightPanel:
      return 0.55;  // the frame; the emissive part is handled in shade()
    case Material::kVent: {
      if (hit.element < 0 || !underside) return 0.5;
      const Eigen::AlignedBox3d& b = elements_[static_cast<std::size_t>(hit.element)].box;
      const double dx = std::min(p.x() - b.min().x(), b.max().x() - p.x());
      const double dy = std::min(p.y() - b.min().y(), b.max().y() - p.y());
      if (dx < 0.03 || dy < 0.03) return 0.66;
      const bool along_x = (b.max().x() - b.min().x()) >= (b.max().y() - b.min().y());
      const double across = along_x ? p.x() - b.min().x() : p.y() - b.min().y();
      return std::fmod(across, 0.025) < 0.01 ? 0.12 : 0.5;
    }
    case Material::kHousing:
      return 0.045 + 0.01 * valueNoise(p.x() / 0.02, p.y() / 0.02, s);
    case Material::kWall: {
      double c = 0.58 * (0.85 + 0.3 * fbm(u / 1.5, v / 1.5, s + 7u, 3)) +
                 0.05 * (valueNoise(u / 0.03, v / 0.03, s + 8u) - 0.5);
      if (p.z() < 1.0) c = 0.36 + 0.05 * (valueNoise(u / 0.05, v / 0.05, s + 9u) - 0.5);
      if (p.z() >= 1.0 && p.z() < 1.12) c = 0.8;
      if (nearLattice(u, 0.6, 0.012) && nearLattice(v, 0.6, 0.012) && p.z() > 1.12) c *= 0.35;
      return c;
    }
    case Material::kRobotBody:
      return 0.25;
    case Material::kMarker:
      return 1.0;
  }
  return 0.0;
}

double World::shade(const Hit& hit) const {
  if (!hit.valid()) return 0.0;
  const Eigen::Vector3d& p = hit.point;
  if (isCeilingMaterial(hit.material) && inLowTextureRegion(p.x(), p.y())) return kLowTextureGrey;
  if (hit.material == Material::kLightPanel && hit.element >= 0 && hit.normal.z() < -0.5) {
    const Eigen::AlignedBox3d& b = elements_[static_cast<std::size_t>(hit.element)].box;
    const double dx = std::min(p.x() - b.min().x(), b.max().x() - p.x());
    const double dy = std::min(p.y() - b.min().y(), b.max().y() - p.y());
    if (dx > 0.025 && dy > 0.025) return 1.6;  // emissive diffuser: saturates
  }
  if (hit.material == Material::kHousing) return albedo(hit);  // dark whatever the light
  return albedo(hit) * illumination(p.x(), p.y());
}

double World::shade(Material material, const Eigen::Vector3d& point,
                    std::uint32_t texture_seed) const {
  Hit hit;
  hit.material = material;
  hit.point = point;
  hit.normal = material == Material::kFloor ? Eigen::Vector3d(Eigen::Vector3d::UnitZ())
                                            : Eigen::Vector3d(-Eigen::Vector3d::UnitZ());
  hit.texture_seed = texture_seed;
  hit.distance = 0.0;
  for (std::size_t k = 0; k < elements_.size(); ++k) {
    if (elements_[k].texture_seed == texture_seed && elements_[k].material == material) {
      hit.element = static_cast<int>(k);
      break;
    }
  }
  return shade(hit);
}

}  // namespace lookboth::sim
