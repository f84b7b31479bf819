// The simulated facility: a floor at z = 0, a ceiling that is not one flat
// plane (slabs at different heights, beams, ducts, light panels, cable
// trays, vents), perimeter walls, the environment cameras' housings hanging
// below the ceiling. World frame: x along the facility's length, y across,
// z up [m]. The robot is not part of the static world (render.h draws it).
//
// Everything is deterministic: the layout from the seed (a private
// SplitMix64 generator, not std:: distributions, so it is the same on every
// standard library), the textures from integer hashes of the seed and of
// lattice cell coordinates (value noise), so a surface point always has the
// same grey level, whichever ray or thread asks.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "lookboth/geometry/rigid3.h"

namespace lookboth::sim {

/// What a ray hit, for shading.
enum class Material : std::uint8_t {
  kNone,         ///< Nothing (ray escaped): black.
  kFloor,        ///< Concrete floor with markings.
  kCeilingSlab,  ///< Painted concrete / acoustic tiles (textured, repetitive).
  kBeam,         ///< Structural beam.
  kDuct,         ///< Metal duct (specular-ish bands).
  kLightPanel,   ///< Emissive, bright.
  kCableTray,    ///< Dark tray with cable texture.
  kVent,         ///< Grille.
  kHousing,      ///< An environment camera's housing: dark (the "blob").
  kRobotBody,    ///< The robot's top plate.
  kMarker,       ///< The backlit marker (bitmap from the real dictionary).
  kWall,         ///< Perimeter wall (what a fisheye sees near its horizon).
};

/// Name of a material ("ceiling_slab", ...), for messages and tests.
const char* materialName(Material material);

/// An axis-aligned box element of the ceiling or the world.
struct Box {
  Eigen::AlignedBox3d box;
  Material material = Material::kCeilingSlab;
  std::uint32_t texture_seed = 0;  ///< Varies the procedural texture per element.
};

/// Generation parameters of a facility (part of a scenario; units metres).
struct WorldSpec {
  double length_m = 40.0;      ///< Along x.
  double width_m = 20.0;       ///< Along y.
  double ceiling_min_m = 3.0;  ///< Lowest ceiling element underside above the floor.
  double ceiling_max_m = 4.0;  ///< Highest slab underside.
  double slab_size_m = 8.0;    ///< Typical side of a ceiling slab (each slab has its own height).
  int beams = 6;               ///< Beams across the width.
  int ducts = 3;               ///< Ducts along the length.
  int light_panels = 40;
  int cable_trays = 4;
  int vents = 20;
  /// A region (x0, y0, x1, y1) of plain, untextured ceiling (a fault: low texture); empty = none.
  std::vector<double> low_texture_region;
  /// Empty when valid; else a message naming the field.
  std::string check() const;
};

/// An environment camera's housing as seen from below: a dark dome (a sphere
/// of radius_m centred on the camera's optical centre, so the blob a fisheye
/// sees from below is centred on the projection of the optical centre) on a
/// thin dark mount post (a vertical cylinder of mount_radius_m reaching
/// height_m above the optical centre; 0 = no post).
struct Housing {
  std::string label;
  Eigen::Vector3d centre_in_world = Eigen::Vector3d::Zero();  ///< The camera's optical centre.
  double radius_m = 0.06;        ///< Radius of the dome (half the housing's horizontal size).
  double height_m = 0.10;        ///< The mount post reaches this much above the optical centre.
  double mount_radius_m = 0.02;  ///< Radius of the mount post (0 = none).
};

/// The first surface a ray meets.
struct Hit {
  double distance = std::numeric_limits<double>::infinity();  ///< Along the (unit) ray [m].
  Material material = Material::kNone;
  Eigen::Vector3d point = Eigen::Vector3d::Zero();   ///< In the world.
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();  ///< Outward unit normal at the point.
  std::uint32_t texture_seed = 0;
  int element = -1;  ///< Index into World::elements(), or -1.
  int housing = -1;  ///< Index into World::housings(), or -1.
  bool valid() const { return material != Material::kNone; }
};

class World {
 public:
  /// Builds a facility from the spec, deterministically from the seed.
  /// Throws lookboth::Error when spec.check() fails.
  World(const WorldSpec& spec, std::uint32_t seed);

  const WorldSpec& spec() const { return spec_; }
  std::uint32_t seed() const { return seed_; }
  const std::vector<Box>& elements() const { return elements_; }
  const std::vector<Housing>& housings() const { return housings_; }
  /// Adds a housing (and re-indexes the world for ray casting).
  void addHousing(const Housing& housing);

  /// Height of the ceiling's underside above (x, y) [m] (the lowest ceiling
  /// element there, walls and housings excluded), for placing cameras on the
  /// ceiling. Inside the facility it lies in [ceiling_min_m, ceiling_max_m];
  /// outside, it is ceiling_max_m.
  double ceilingHeightAt(double x, double y) const;

  /// First hit of the ray origin + s * direction (direction unit, s > 0) with
  /// the static world (floor, walls, ceiling elements, housings). Surfaces
  /// are one-sided: a ray starting inside an element (or a housing) does not
  /// hit it from inside, so a camera inside its own housing sees out.
  Hit intersect(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction) const;
  /// The same; returns the distance s (+inf when nothing is hit) and fills
  /// the outputs that are not null.
  double intersect(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                   Material* material, Eigen::Vector3d* point, std::uint32_t* texture_seed) const;

  /// Radiance of a hit surface, as a grey level (0 black, 1 a well-lit white
  /// surface; emissive light panels exceed 1 and saturate).
  double shade(const Hit& hit) const;
  /// The same without the face: assumes the face that looks at the floor
  /// (undersides; +z for the floor).
  double shade(Material material, const Eigen::Vector3d& point, std::uint32_t texture_seed) const;

  /// Relative illumination of the facility at (x, y) by its light panels
  /// (about 0.55 between lights, up to 1 under them); smooth.
  double illumination(double x, double y) const;
  /// True when (x, y) lies in the spec's low-texture region.
  bool inLowTextureRegion(double x, double y) const;

 private:
  struct Grid {
    double x0 = 0, y0 = 0, cell = 0.5;
    int nx = 0, ny = 0;
    std::vector<std::uint32_t> start;   ///< CSR offsets, nx * ny + 1.
    std::vector<std::uint32_t> items;   ///< Primitive ids: element index, or elements + housing.
    std::vector<float> zlo, zhi;        ///< Vertical extent of the cell's primitives.
    double zlo_all = 0, zhi_all = 0;    ///< Vertical extent of all indexed primitives.
    std::vector<std::uint32_t> always;  ///< Elements tested for every ray (the walls).
  };
  void buildGrid();
  bool hitPrimitive(std::uint32_t id, const Eigen::Vector3d& origin,
                    const Eigen::Vector3d& direction, const Eigen::Vector3d& inverse_direction,
                    Hit* best) const;
  void hitWalls(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                const Eigen::Vector3d& inverse_direction, Hit* best) const;
  double albedo(const Hit& hit) const;

  WorldSpec spec_;
  std::uint32_t seed_ = 0;
  std::vector<Box> elements_;
  std::vector<Housing> housings_;
  Grid grid_;
  int walls_[4] = {-1, -1, -1,
                   -1};  ///< Elements: the walls at x = 0, x = length, y = 0, y = width.
  double wall_top_ = 0.0;
  // Illumination map over the grid's extent.
  double light_x0_ = 0, light_y0_ = 0, light_cell_ = 0.5;
  int light_nx_ = 0, light_ny_ = 0;
  std::vector<float> light_map_;
};

/// Entering hit of a ray with an axis-aligned box (slab method): false when
/// the ray misses it or starts inside it (one-sided); else the distance
/// (> 0) and the outward normal of the face hit.
bool rayBoxEntry(const Eigen::AlignedBox3d& box, const Eigen::Vector3d& origin,
                 const Eigen::Vector3d& direction, double* distance, Eigen::Vector3d* normal);

/// Value noise in [0, 1]: smooth interpolation of hashed values on the
/// integer lattice of (x, y); deterministic in (x, y, seed).
double valueNoise(double x, double y, std::uint32_t seed);

}  // namespace lookboth::sim
