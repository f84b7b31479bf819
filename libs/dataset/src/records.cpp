#include "lookboth/dataset/records.h"

#include <Eigen/LU>

namespace lookboth {

std::optional<Eigen::Matrix<double, 6, 6>> markerCovariance(const MarkerObservation& detection) {
  if (detection.information.isZero(0)) return std::nullopt;
  const Eigen::FullPivLU<Eigen::Matrix<double, 6, 6>> lu(detection.information);
  if (!lu.isInvertible()) return std::nullopt;
  const Eigen::Matrix<double, 6, 6> covariance = lu.inverse();
  return Eigen::Matrix<double, 6, 6>(0.5 * (covariance + covariance.transpose()));
}

TimeNs recordTime(const Record& record) {
  return std::visit([](const auto& r) { return r.t; }, record);
}

const std::string& recordLabel(const Record& record) {
  struct Visitor {
    const std::string& operator()(const ImageFrame& r) const { return r.sensor; }
    const std::string& operator()(const MarkerObservation& r) const { return r.camera; }
    const std::string& operator()(const BlobObservation& r) const { return r.camera; }
    const std::string& operator()(const PoseSample& r) const { return r.label; }
  };
  return std::visit(Visitor{}, record);
}

const char* recordKindName(const Record& record) {
  static const char* kNames[] = {"image", "marker", "blobs", "pose"};
  return kNames[record.index()];
}

}  // namespace lookboth
