#include "lookboth/obs/CObservationBlobs.h"

#include <mrpt/rtti/CObject.h>
#include <mrpt/serialization/CArchive.h>

#include <charconv>
#include <iomanip>
#include <sstream>

#include "lookboth/obs/CObservationMarkerCorners.h"

namespace lookboth {

IMPLEMENTS_SERIALIZABLE(CObservationBlobs, mrpt::obs::CObservation, lookboth)

// Format version 0: timestamp, sensorLabel, sensorPose, image size, blobs.
uint8_t CObservationBlobs::serializeGetVersion() const { return 0; }

void CObservationBlobs::serializeTo(mrpt::serialization::CArchive& out) const {
  out << timestamp << sensorLabel << sensorPose;
  out.WriteAs<int32_t>(image_width);
  out.WriteAs<int32_t>(image_height);
  out.WriteAs<uint32_t>(blobs.size());
  for (const Blob& b : blobs) out << b.u << b.v << b.diameter_px << b.response;
}

void CObservationBlobs::serializeFrom(mrpt::serialization::CArchive& in, uint8_t version) {
  switch (version) {
    case 0: {
      in >> timestamp >> sensorLabel >> sensorPose;
      image_width = in.ReadAs<int32_t>();
      image_height = in.ReadAs<int32_t>();
      const uint32_t n = in.ReadAs<uint32_t>();
      blobs.resize(n);
      for (Blob& b : blobs) in >> b.u >> b.v >> b.diameter_px >> b.response;
      break;
    }
    default:
      MRPT_THROW_UNKNOWN_SERIALIZATION_VERSION(version);
  }
}

void CObservationBlobs::getDescriptionAsText(std::ostream& o) const {
  CObservation::getDescriptionAsText(o);
  o << "lookboth blobs (environment cameras seen from below)\n";
  o << "Sensor pose on the robot: " << sensorPose << "\n";
  o << "Image size: " << image_width << " x " << image_height << " px\n";
  o << "Number of blobs: " << blobs.size() << "\n";
  o << "   #        u [px]       v [px]  diameter [px]   response\n";
  for (size_t i = 0; i < blobs.size(); ++i) {
    const Blob& b = blobs[i];
    o << std::setw(4) << i << std::fixed << std::setprecision(3) << std::setw(14) << b.u
      << std::setw(13) << b.v << std::setw(15) << b.diameter_px << std::setw(11) << b.response
      << "\n";
  }
}

std::string CObservationBlobs::exportTxtHeader() const {
  return "[U_PX V_PX DIAMETER_PX RESPONSE]...";
}

std::string CObservationBlobs::exportTxtDataRow() const {
  // Shortest text that reads back exactly, with a decimal point in any locale.
  std::string row;
  char buffer[32];
  for (const Blob& b : blobs) {
    for (double value : {b.u, b.v, b.diameter_px, b.response}) {
      const auto result = std::to_chars(buffer, buffer + sizeof(buffer), value);
      row.append(buffer, result.ptr);
      row += ' ';
    }
  }
  return row;
}

void registerLookbothObservations() {
  mrpt::rtti::registerClass(CLASS_ID(CObservationBlobs));
  mrpt::rtti::registerClass(CLASS_ID(CObservationMarkerCorners));
}

namespace {

// Registered when the library loads, by a static object defined after
// IMPLEMENTS_SERIALIZABLE: its runtimeClassId holds a std::function, so it is
// built by a dynamic initialiser, and C++ runs this file's initialisers in
// order. MRPT_INITIALIZER is a constructor function instead, which clang runs
// before them: it registered a class id not built yet (a null name), and no
// rawlog with this class could be read.
const struct RegisterBlobs {
  RegisterBlobs() { mrpt::rtti::registerClass(CLASS_ID(CObservationBlobs)); }
} register_blobs;

}  // namespace

}  // namespace lookboth
