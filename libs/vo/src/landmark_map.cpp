#include "lookboth/vo/landmark_map.h"

#include <algorithm>
#include <cctype>

#include "lookboth/core/atomic_file.h"
#include "lookboth/core/error.h"
#include "lookboth/core/text.h"

namespace lookboth::vo {

LandmarkMapFormat landmarkMapFormatOf(const std::filesystem::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (ext == ".ply") return LandmarkMapFormat::kPly;
  if (ext == ".txt") return LandmarkMapFormat::kMrptText;
  throw Error(path.string() +
              ": unknown landmark map format (the extension must be .ply or .txt, for MRPT "
              "CSimplePointsMap text)");
}

void writeLandmarkMap(const std::filesystem::path& path, const std::vector<MapPoint>& points) {
  const LandmarkMapFormat format = landmarkMapFormatOf(path);
  AtomicOutputFile file(path);
  std::ostream& out = file.stream();
  if (format == LandmarkMapFormat::kPly) {
    out << "ply\nformat ascii 1.0\n"
        << "comment lookboth odometry landmarks: world = the first keyframe of the odometry, "
           "units of the odometry (unknown monocular scale)\n"
        << "element vertex " << points.size() << "\n"
        << "property double x\nproperty double y\nproperty double z\n"
        << "property int observations\nend_header\n";
    for (const MapPoint& p : points) {
      out << formatDouble(p.p_in_world.x()) << ' ' << formatDouble(p.p_in_world.y()) << ' '
          << formatDouble(p.p_in_world.z()) << ' ' << p.observations << '\n';
    }
  } else {
    for (const MapPoint& p : points) {
      out << formatDouble(p.p_in_world.x()) << ' ' << formatDouble(p.p_in_world.y()) << ' '
          << formatDouble(p.p_in_world.z()) << '\n';
    }
  }
  file.commit();
}

}  // namespace lookboth::vo
