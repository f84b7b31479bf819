// The odometry's landmark map as a point cloud file (`lookboth odometry
// --map`): the valid landmarks after the final global adjustment, in the
// world frame of the odometry (world = the first keyframe, VO units, i.e.
// the unknown monocular scale). Format by the file's extension:
//   .ply  ASCII PLY: vertices x y z (double) and `observations` (int, the
//         keyframes that saw the landmark); comments name the frame and units;
//   .txt  MRPT `CSimplePointsMap` text (`load3D_from_text_file`): "x y z" per line.
// Fields in doc/formats.md, "Landmark map (`lookboth odometry --map`)".
#pragma once

#include <filesystem>
#include <vector>

#include "lookboth/vo/odometry.h"

namespace lookboth::vo {

enum class LandmarkMapFormat { kPly, kMrptText };

/// The format of a path by its extension (.ply, .txt, any case); throws
/// lookboth::Error naming the path for any other extension.
LandmarkMapFormat landmarkMapFormatOf(const std::filesystem::path& path);

/// Writes the points atomically (temporary name, then rename; an existing
/// file is replaced). Throws lookboth::Error naming the path.
void writeLandmarkMap(const std::filesystem::path& path, const std::vector<MapPoint>& points);

}  // namespace lookboth::vo
