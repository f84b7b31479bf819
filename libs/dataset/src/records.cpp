#include "lookboth/dataset/records.h"

namespace lookboth {

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
