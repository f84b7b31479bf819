#include "lookboth/obs/CObservationMarkerCorners.h"

#include <mrpt/serialization/CArchive.h>

#include <charconv>
#include <iomanip>

namespace lookboth {

IMPLEMENTS_SERIALIZABLE(CObservationMarkerCorners, mrpt::obs::CObservation, lookboth)

namespace {

// Registered when the library loads, after the class id above is built (see
// CObservationBlobs.cpp for why not MRPT_INITIALIZER).
const struct RegisterMarkerCorners {
  RegisterMarkerCorners() { mrpt::rtti::registerClass(CLASS_ID(CObservationMarkerCorners)); }
} register_marker_corners;

}  // namespace

// Format version 0: timestamp, sensorLabel, sensorPose, marker id, 4 x (u, v), corner sigma.
uint8_t CObservationMarkerCorners::serializeGetVersion() const { return 0; }

void CObservationMarkerCorners::serializeTo(mrpt::serialization::CArchive& out) const {
  out << timestamp << sensorLabel << sensorPose;
  out.WriteAs<int32_t>(marker_id);
  for (const CornerPixel& c : corners) out << c.u << c.v;
  out << corner_sigma_px;
}

void CObservationMarkerCorners::serializeFrom(mrpt::serialization::CArchive& in, uint8_t version) {
  switch (version) {
    case 0: {
      in >> timestamp >> sensorLabel >> sensorPose;
      marker_id = in.ReadAs<int32_t>();
      for (CornerPixel& c : corners) in >> c.u >> c.v;
      in >> corner_sigma_px;
      break;
    }
    default:
      MRPT_THROW_UNKNOWN_SERIALIZATION_VERSION(version);
  }
}

void CObservationMarkerCorners::getDescriptionAsText(std::ostream& o) const {
  CObservation::getDescriptionAsText(o);
  o << "lookboth marker corners (pairs with the CObservation6DFeatures of the same label and "
       "timestamp)\n";
  o << "Sensor pose: " << sensorPose << "\n";
  o << "Marker id: " << marker_id << "\n";
  o << "Corner sigma: " << corner_sigma_px << " px\n";
  o << "   #        u [px]       v [px]\n";
  for (size_t i = 0; i < corners.size(); ++i) {
    o << std::setw(4) << i << std::fixed << std::setprecision(3) << std::setw(14) << corners[i].u
      << std::setw(13) << corners[i].v << "\n";
  }
}

std::string CObservationMarkerCorners::exportTxtHeader() const {
  return "MARKER_ID U0 V0 U1 V1 U2 V2 U3 V3 CORNER_SIGMA_PX";
}

std::string CObservationMarkerCorners::exportTxtDataRow() const {
  // Shortest text that reads back exactly, with a decimal point in any locale.
  std::string row = std::to_string(marker_id);
  char buffer[32];
  auto append = [&](double value) {
    const auto result = std::to_chars(buffer, buffer + sizeof(buffer), value);
    row += ' ';
    row.append(buffer, result.ptr);
  };
  for (const CornerPixel& c : corners) {
    append(c.u);
    append(c.v);
  }
  append(corner_sigma_px);
  return row;
}

}  // namespace lookboth
