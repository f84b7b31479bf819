// The four image corners of a marker whose pose an environment camera's
// mrpt::obs::CObservation6DFeatures holds. CObservation6DFeatures has no place
// for them, so a lookboth rawlog writes this observation right after the
// 6DFeatures it belongs to, with the same sensorLabel, timestamp and marker id
// (doc/formats.md, "Dataset (rawlog + manifest)"). Tools that do not know this
// class still read the pose; lookboth's reader pairs the two.
#pragma once

#include <mrpt/obs/CObservation.h>
#include <mrpt/poses/CPose3D.h>

#include <array>
#include <cstdint>

namespace lookboth {

/// One image point [px]; (0,0) is the centre of the top-left pixel.
struct CornerPixel {
  double u = 0;  ///< Column [px].
  double v = 0;  ///< Row [px].
};

class CObservationMarkerCorners : public mrpt::obs::CObservation {
  DEFINE_SERIALIZABLE(CObservationMarkerCorners, lookboth)

 public:
  /// Id of the marker (the `id` of the paired 6DFeatures measurement).
  int32_t marker_id = 0;
  /// The corners in the marker's order: marker-frame (-s/2, s/2, 0),
  /// (s/2, s/2, 0), (s/2, -s/2, 0), (-s/2, -s/2, 0) for a marker of side s
  /// (OpenCV ArUco's top-left, top-right, bottom-right, bottom-left).
  std::array<CornerPixel, 4> corners{};
  /// Standard deviation of one corner coordinate [px]; 0 when unknown.
  double corner_sigma_px = 0;
  /// Pose of the camera on its robot (MRPT's sensor pose: robot_from_camera);
  /// identity for a fixed environment camera.
  mrpt::poses::CPose3D sensorPose;

  void getSensorPose(mrpt::poses::CPose3D& out_sensor_pose) const override {
    out_sensor_pose = sensorPose;
  }
  void setSensorPose(const mrpt::poses::CPose3D& new_sensor_pose) override {
    sensorPose = new_sensor_pose;
  }
  void getDescriptionAsText(std::ostream& o) const override;

  bool exportTxtSupported() const override { return true; }
  std::string exportTxtHeader() const override;
  std::string exportTxtDataRow() const override;
};

}  // namespace lookboth
