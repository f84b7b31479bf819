// Blobs detected in one camera frame: in lookboth, the environment cameras'
// housings seen as dark blobs by the robot's upward fisheye (the paper's
// "looking up" measurements). MRPT has no single-camera keypoint observation,
// so this is lookboth's own serializable class; the shared library that holds
// it loads as a plugin into MRPT's tools:
//     rawlog-edit -p liblookboth-obs.so -i x.rawlog --info
//     RawLogViewer -l liblookboth-obs.so x.rawlog
#pragma once

#include <mrpt/obs/CObservation.h>
#include <mrpt/poses/CPose3D.h>

#include <vector>

namespace lookboth {

/// One blob. Pixel convention: (0,0) is the centre of the top-left pixel.
struct Blob {
  double u = 0;            ///< Centre column [px].
  double v = 0;            ///< Centre row [px].
  double diameter_px = 0;  ///< Diameter [px] (OpenCV KeyPoint::size).
  double response = 0;  ///< Detector strength (OpenCV KeyPoint::response), unitless; 0 if unknown.
};

class CObservationBlobs : public mrpt::obs::CObservation {
  DEFINE_SERIALIZABLE(CObservationBlobs, lookboth)

 public:
  /// Blobs of one frame of the camera named by `sensorLabel`, stamped with
  /// that frame's `timestamp`.
  std::vector<Blob> blobs;
  /// Image size of the frame the blobs come from [px] (0 when unknown).
  int image_width = 0;
  int image_height = 0;
  /// Pose of the camera on the robot (MRPT's sensor pose convention: robot_from_camera).
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

/// Registers lookboth's observation classes with MRPT's class registry. It
/// also runs automatically when the library is loaded; calling it references
/// the library so that `--as-needed` linking cannot drop it.
void registerLookbothObservations();

}  // namespace lookboth
