// MRPT: the registration as a pose graph (registration.graph, written by
// MRPT's own CNetworkOfPoses3DCov, read by `graph-slam --3d`): one node per
// trajectory pose, then one per camera; an edge between consecutive
// trajectory poses (their relative pose, the covariance of the joint
// adjustment's motion prior), and one from the trajectory pose nearest each
// camera to the camera (the camera's covariance); plus each camera as a
// CPose3DPDFGaussian in cameras_pdf.txt (its mean and covariance) and in
// cameras.rawlog (a CObservationRobotPose per camera, its sensorLabel the
// camera's label: RawLogViewer and rawlog-edit read it).
#include <yaml-cpp/yaml.h>

#include <mrpt/graphs/CNetworkOfPoses.h>
#include <mrpt/io/CMemoryStream.h>
#include <mrpt/obs/CObservationRobotPose.h>
#include <mrpt/poses/CPose3DPDFGaussian.h>
#include <mrpt/serialization/CArchive.h>
#include <cmath>
#include <limits>
#include <sstream>

#include "formats.h"
#include "lookboth/core/error.h"
#include "lookboth/core/text.h"
#include "lookboth/geometry/lie.h"
#include "lookboth/geometry/pose_conversions.h"
#include "lookboth/geometry/time.h"

namespace lookboth::export_detail {
namespace {

using mrpt::poses::CPose3D;
using mrpt::poses::CPose3DPDFGaussian;

struct MotionSigmas {
  double m_per_sqrt_m = 0.01, deg_per_sqrt_m = 0.2, min_m = 0.0005, min_deg = 0.005;
};

/// The joint's motion prior as the registration ran it: its configured
/// drift model times the factors it estimated.
MotionSigmas motionSigmas(const Registration& reg) {
  MotionSigmas s;
  try {
    const YAML::Node joint = YAML::Load(reg.config_yaml)["joint"];
    if (joint && joint.IsMap()) {
      if (joint["drift_m_per_sqrt_m"]) s.m_per_sqrt_m = joint["drift_m_per_sqrt_m"].as<double>();
      if (joint["drift_deg_per_sqrt_m"]) {
        s.deg_per_sqrt_m = joint["drift_deg_per_sqrt_m"].as<double>();
      }
      if (joint["min_sigma_m"]) s.min_m = joint["min_sigma_m"].as<double>();
      if (joint["min_sigma_deg"]) s.min_deg = joint["min_sigma_deg"].as<double>();
    }
  } catch (const YAML::Exception&) {
    // The defaults above: the configuration is what register wrote.
  }
  if (const auto& drift = reg.observability.drift_model) {
    s.m_per_sqrt_m *= drift->horizontal;
    s.deg_per_sqrt_m *= drift->yaw;
  }
  return s;
}

Matrix6d motionCovariance(const MotionSigmas& s, double distance_m) {
  const double t = std::max(s.min_m, s.m_per_sqrt_m * std::sqrt(distance_m));
  const double r = std::max(s.min_deg, s.deg_per_sqrt_m * std::sqrt(distance_m)) * M_PI / 180;
  Matrix6d covariance = Matrix6d::Zero();
  covariance.diagonal() << t * t, t * t, t * t, r * r, r * r, r * r;
  return covariance;
}

/// The trajectory pose nearest the camera (the robot passes under it).
std::size_t nearestPose(const std::vector<StampedPose>& trajectory, const Rigid3d& camera) {
  std::size_t best = 0;
  double best_distance = std::numeric_limits<double>::infinity();
  for (std::size_t k = 0; k < trajectory.size(); ++k) {
    const double d = (trajectory[k].world_from_body.translation - camera.translation).norm();
    if (d < best_distance) {
      best_distance = d;
      best = k;
    }
  }
  return best;
}

void addTrajectory(const Registration& reg, mrpt::graphs::CNetworkOfPoses3DCov* graph) {
  const MotionSigmas sigmas = motionSigmas(reg);
  for (std::size_t k = 0; k < reg.trajectory.size(); ++k) {
    graph->nodes[k] = toMrptPose(reg.trajectory[k].world_from_body);
    if (k == 0) continue;
    const Rigid3d& a = reg.trajectory[k - 1].world_from_body;
    const Rigid3d& b = reg.trajectory[k].world_from_body;
    const Rigid3d relative = a.inverse() * b;
    graph->insertEdge(
        k - 1, k, toMrptPosePdf(relative, motionCovariance(sigmas, relative.translation.norm())));
  }
}

}  // namespace

void writeMrpt(const ExportContext& context) {
  const Registration& reg = context.registration;
  if (reg.trajectory.empty()) {
    throw Error(
        "export mrpt: the registration has no trajectory (trajectory.tum) to make "
        "the graph's nodes");
  }
  mrpt::graphs::CNetworkOfPoses3DCov graph;
  graph.root = 0;
  addTrajectory(reg, &graph);
  std::ostringstream pdfs;
  pdfs << "# label x y z yaw pitch roll [m, rad], then the 6x6 covariance over them, rows first\n";
  // Each camera's pose PDF also as MRPT observations (cameras.rawlog:
  // uncompressed, which MRPT reads as it reads gzip), stamped with the
  // drive's end, the registration's time.
  mrpt::io::CMemoryStream rawlog;
  auto archive = mrpt::serialization::archiveFrom(rawlog);
  std::size_t id = reg.trajectory.size();
  for (const ExportedCamera& c : context.cameras) {
    const CameraRegistration& camera = *c.registration;
    const Matrix6d covariance = camera.covariance.value_or(Matrix6d::Identity() * 1e-4);
    graph.nodes[id] = toMrptPose(camera.world_from_camera);
    const std::size_t k = nearestPose(reg.trajectory, camera.world_from_camera);
    const Rigid3d& node = reg.trajectory[k].world_from_body;
    // The camera relative to the node: translation in the node's frame,
    // the rotation's right perturbation unchanged.
    Matrix6d turn = Matrix6d::Identity();
    turn.topLeftCorner<3, 3>() = node.rotation.toRotationMatrix().transpose();
    graph.insertEdge(k, id,
                     toMrptPosePdf(node.inverse() * camera.world_from_camera,
                                   turn * covariance * turn.transpose()));
    const CPose3DPDFGaussian pdf = toMrptPosePdf(camera.world_from_camera, covariance);
    mrpt::obs::CObservationRobotPose observation;
    observation.sensorLabel = camera.label;
    observation.timestamp = toMrptTime(reg.trajectory.back().t);
    observation.pose = pdf;
    archive << observation;
    pdfs << camera.label;
    for (double v : {pdf.mean.x(), pdf.mean.y(), pdf.mean.z(), pdf.mean.yaw(), pdf.mean.pitch(),
                     pdf.mean.roll()}) {
      pdfs << " " << formatDouble(v);
    }
    for (int r = 0; r < 6; ++r) {
      for (int col = 0; col < 6; ++col) pdfs << " " << formatDouble(pdf.cov(r, col));
    }
    pdfs << "\n";
    ++id;
  }
  std::ostringstream text;
  text.precision(17);  // MRPT writes through the stream: all the digits of a double
  graph.writeAsText(text);
  context.write("registration.graph", text.str());
  context.write("cameras_pdf.txt", pdfs.str());
  const auto* bytes = static_cast<const char*>(rawlog.getRawBufferData());
  context.write("cameras.rawlog", std::string(bytes, bytes + rawlog.getTotalBytesCount()));
}

}  // namespace lookboth::export_detail
