// TUM RGB-D trajectory files: one pose per line,
//     timestamp tx ty tz qx qy qz qw
// timestamp in seconds (decimal, read exactly to the nanosecond), the pose is
// world_from_body (the position of the body in the world and its orientation,
// quaternion in Hamilton convention, TUM order x y z w). Lines starting with
// '#' and blank lines are comments.
#pragma once

#include <filesystem>
#include <string>

#include "lookboth/core/error.h"
#include "lookboth/geometry/trajectory.h"

namespace lookboth {

/// "1305031102.175304000 tx ty tz qx qy qz qw" with full double precision.
std::string formatTumRow(const StampedPose& sample);

/// Parses one non-comment row. Throws lookboth::Error with `where` (file and
/// line) on a wrong field count, a bad number or a quaternion whose norm is
/// off by more than 1e-3 (smaller deviations are normalised away).
StampedPose parseTumRow(const std::string& line, const ErrorContext& where);

/// Reads a whole file. Timestamps must strictly increase (an error names the
/// line of a duplicate or out-of-order stamp).
Trajectory readTumFile(const std::filesystem::path& path);

/// Writes atomically (temporary name, then rename), with a '#' header line.
void writeTumFile(const std::filesystem::path& path, const Trajectory& trajectory);

}  // namespace lookboth
