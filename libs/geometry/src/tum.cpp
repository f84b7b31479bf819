#include "lookboth/geometry/tum.h"

#include <cmath>
#include <sstream>

#include "lookboth/core/atomic_file.h"
#include "lookboth/core/text.h"
#include "lookboth/geometry/pose_conversions.h"

namespace lookboth {

std::string formatTumRow(const StampedPose& sample) {
  const Eigen::Matrix<double, 7, 1> v = toTumVector(sample.world_from_body);
  std::string row = formatSeconds(sample.t);
  for (int i = 0; i < 7; ++i) row += " " + formatDouble(v[i]);
  return row;
}

StampedPose parseTumRow(const std::string& line, const ErrorContext& where) {
  const std::vector<std::string> tokens = splitWhitespace(line);
  if (tokens.size() != 8) {
    throw Error(where, "expected 8 values 'timestamp tx ty tz qx qy qz qw', got " +
                           std::to_string(tokens.size()));
  }
  StampedPose sample;
  const auto t = parseSeconds(tokens[0]);
  if (!t) throw Error(where, "bad timestamp '" + tokens[0] + "'");
  sample.t = *t;
  static const char* kNames[7] = {"tx", "ty", "tz", "qx", "qy", "qz", "qw"};
  Eigen::Matrix<double, 7, 1> v;
  for (int i = 0; i < 7; ++i) {
    const auto value = parseDouble(tokens[i + 1]);
    if (!value || !std::isfinite(*value)) {
      throw Error(where, std::string("bad number '") + tokens[i + 1] + "' for " + kNames[i]);
    }
    v[i] = *value;
  }
  const double norm = v.tail<4>().norm();
  if (std::abs(norm - 1.0) > 1e-3) {
    throw Error(where, "quaternion (qx qy qz qw) has norm " + formatFixed(norm, 6) +
                           ", expected a unit quaternion");
  }
  sample.world_from_body = fromTumVector(v);
  return sample;
}

Trajectory readTumFile(const std::filesystem::path& path) {
  std::istringstream in(readFile(path));
  std::vector<StampedPose> samples;
  std::string line;
  int line_number = 0;
  while (std::getline(in, line)) {
    ++line_number;
    // A byte-order mark (written by some editors) is not part of the first line.
    if (line_number == 1 && line.compare(0, 3, "\xEF\xBB\xBF") == 0) line.erase(0, 3);
    const auto first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    const ErrorContext where{path.string(), line_number, "", ""};
    StampedPose sample = parseTumRow(line, where);
    if (!samples.empty() && sample.t <= samples.back().t) {
      throw Error(where,
                  "timestamp " + formatSeconds(sample.t) +
                      (sample.t == samples.back().t ? " repeats the previous one"
                                                    : " is earlier than the previous one (" +
                                                          formatSeconds(samples.back().t) + ")") +
                      ": timestamps must strictly increase");
    }
    samples.push_back(sample);
  }
  return Trajectory(std::move(samples));
}

void writeTumFile(const std::filesystem::path& path, const Trajectory& trajectory) {
  AtomicOutputFile out(path);
  out.stream() << "# timestamp[s] tx ty tz qx qy qz qw (world_from_body)\n";
  for (const StampedPose& sample : trajectory.samples())
    out.stream() << formatTumRow(sample) << '\n';
  out.commit();
}

}  // namespace lookboth
