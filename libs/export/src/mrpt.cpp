// MRPT: the registration as a pose graph (registration.graph, written by
// MRPT's own CNetworkOfPoses3DCov, read by `graph-slam --3d`): one node per
// trajectory pose, then one per camera; the edges are the measurements, so
// that MRPT's optimiser can redo the adjustment: consecutive trajectory
// poses (their relative pose, the covariance of the joint adjustment's
// motion prior), each detection of the robot's marker (trajectory node to
// camera, the detection's covariance), each blob associated with a camera
// (trajectory node to camera, a bearing: loose along its ray and in
// rotation); a camera without detections gets one edge from the trajectory
// pose nearest it with its registered covariance. Plus each camera as a
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
#include <map>
#include <sstream>

#include "formats.h"
#include "graph_edges.h"
#include "lookboth/core/error.h"
#include "lookboth/core/text.h"
#include "lookboth/geometry/lie.h"
#include "lookboth/geometry/pose_conversions.h"
#include "lookboth/geometry/time.h"

namespace lookboth::export_detail {
namespace {

using mrpt::poses::CPose3D;
using mrpt::poses::CPose3DPDFGaussian;

/// What the joint adjustment weighted its inputs with, as the registration
/// ran it (its configuration, the drift factors it estimated).
struct GraphSigmas {
  double m_per_sqrt_m = 0.01, deg_per_sqrt_m = 0.2, min_m = 0.0005, min_deg = 0.005;
  double blob_px = 1.0;
  double default_m = 0.01, default_deg = 2.0;  ///< A detection without an information matrix.
};

double readDouble(const YAML::Node& section, const char* key, double fallback) {
  return section[key] ? section[key].as<double>() : fallback;
}

GraphSigmas graphSigmas(const Registration& reg) {
  GraphSigmas s;
  try {
    const YAML::Node joint = YAML::Load(reg.config_yaml)["joint"];
    if (joint && joint.IsMap()) {
      s.m_per_sqrt_m = readDouble(joint, "drift_m_per_sqrt_m", s.m_per_sqrt_m);
      s.deg_per_sqrt_m = readDouble(joint, "drift_deg_per_sqrt_m", s.deg_per_sqrt_m);
      s.min_m = readDouble(joint, "min_sigma_m", s.min_m);
      s.min_deg = readDouble(joint, "min_sigma_deg", s.min_deg);
      s.blob_px = readDouble(joint, "blob_sigma_px", s.blob_px);
      s.default_m = readDouble(joint, "default_translation_sigma_m", s.default_m);
      s.default_deg = readDouble(joint, "default_rotation_sigma_deg", s.default_deg);
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

Matrix6d diagonalCovariance(double sigma_m, double sigma_rad) {
  Matrix6d covariance = Matrix6d::Zero();
  covariance.diagonal() << sigma_m * sigma_m, sigma_m * sigma_m, sigma_m * sigma_m,
      sigma_rad * sigma_rad, sigma_rad * sigma_rad, sigma_rad * sigma_rad;
  return covariance;
}

Matrix6d motionCovariance(const GraphSigmas& s, double distance_m) {
  const double t = std::max(s.min_m, s.m_per_sqrt_m * std::sqrt(distance_m));
  const double r = std::max(s.min_deg, s.deg_per_sqrt_m * std::sqrt(distance_m)) * M_PI / 180;
  return diagonalCovariance(t, r);
}

/// Squared Mahalanobis distance beyond which a marker detection is left out
/// of the graph: 10 sigmas, an outlier by any measure (the registration set
/// it aside; MRPT's graph optimisers have no robust loss to do so).
constexpr double kMarkerEdgeGateChi2 = 100;

/// Builds the graph step by step: the trajectory, the cameras, their edges.
class GraphBuilder {
 public:
  explicit GraphBuilder(const ExportContext& context)
      : context_(context),
        reg_(context.registration),
        sigmas_(graphSigmas(reg_)),
        trajectory_(reg_.trajectory) {
    graph_.root = 0;
  }

  void addTrajectory() {
    for (std::size_t k = 0; k < reg_.trajectory.size(); ++k) {
      graph_.nodes[k] = toMrptPose(reg_.trajectory[k].world_from_body);
      if (k == 0) continue;
      const Rigid3d relative =
          reg_.trajectory[k - 1].world_from_body.inverse() * reg_.trajectory[k].world_from_body;
      graph_.insertEdge(
          k - 1, k,
          toMrptPosePdf(relative, motionCovariance(sigmas_, relative.translation.norm())));
    }
  }

  void addCameraNodes() {
    std::size_t id = reg_.trajectory.size();
    for (const ExportedCamera& c : context_.cameras) {
      graph_.nodes[id] = toMrptPose(c.registration->world_from_camera);
      node_of_[c.registration->label] = id++;
    }
  }

  void addMarkerEdges() {
    const Matrix6d fallback =
        diagonalCovariance(sigmas_.default_m, sigmas_.default_deg * M_PI / 180);
    for (const MarkerObservation& detection : context_.sources.marker_detections) {
      const CameraRegistration* camera = exportedCamera(detection.camera);
      if (camera == nullptr) continue;
      const TimeNs offset = camera->clock_offset ? camera->clock_offset->offset_ns : 0;
      const std::optional<PoseEdge> edge =
          markerEdge(trajectory_, detection, offset, reg_.fisheye_from_marker, fallback);
      if (!edge) continue;
      if (edgeChi2(*edge, registeredRelative(*edge, *camera)) > kMarkerEdgeGateChi2) {
        ++markers_left_out_;
        continue;
      }
      insert(*edge, camera->label);
      ++marker_edges_[camera->label];
    }
  }

  void addBlobEdges() {
    const auto fisheye = context_.sources.intrinsics.find(context_.sources.fisheye);
    if (fisheye == context_.sources.intrinsics.end()) return;
    for (const BlobAssociation& blob : reg_.blob_associations) {
      const CameraRegistration* camera = exportedCamera(blob.camera);
      if (camera == nullptr) continue;
      const std::optional<PoseEdge> edge =
          blobEdge(trajectory_, blob, fisheye->second, camera->world_from_camera, sigmas_.blob_px);
      if (!edge) continue;
      insert(*edge, camera->label);
      ++blob_edges_;
    }
  }

  /// A camera no detection reached: one edge from the trajectory pose
  /// nearest it, its registered covariance in that pose's frame.
  void addCovarianceEdges() {
    for (const ExportedCamera& c : context_.cameras) {
      const CameraRegistration& camera = *c.registration;
      if (marker_edges_.count(camera.label) != 0) continue;
      const Matrix6d covariance = camera.covariance.value_or(Matrix6d::Identity() * 1e-4);
      const std::size_t k = nearestPose(camera.world_from_camera);
      const Rigid3d& node = reg_.trajectory[k].world_from_body;
      // Translation into the node's frame; the right perturbation of the
      // rotation is unchanged.
      Matrix6d turn = Matrix6d::Identity();
      turn.topLeftCorner<3, 3>() = node.rotation.toRotationMatrix().transpose();
      insert({k, false, node.inverse() * camera.world_from_camera,
              turn * covariance * turn.transpose()},
             camera.label);
      ++covariance_edges_;
    }
  }

  const mrpt::graphs::CNetworkOfPoses3DCov& graph() const { return graph_; }

  std::string summary() const {
    int markers = 0;
    for (const auto& [label, n] : marker_edges_) markers += n;
    std::string text = "registration.graph: " + std::to_string(markers) + " marker detection, " +
                       std::to_string(blob_edges_) + " blob and " +
                       std::to_string(covariance_edges_) + " registered-covariance edges";
    if (markers_left_out_ > 0) {
      text += "; " + std::to_string(markers_left_out_) +
              " marker detections left out, more than 10 sigmas from the registration";
    }
    return text;
  }

 private:
  const CameraRegistration* exportedCamera(const std::string& label) const {
    if (node_of_.count(label) == 0) return nullptr;
    return reg_.findCamera(label);
  }

  Rigid3d registeredRelative(const PoseEdge& edge, const CameraRegistration& camera) const {
    const Rigid3d node_from_camera =
        reg_.trajectory[edge.node].world_from_body.inverse() * camera.world_from_camera;
    return edge.from_camera ? node_from_camera.inverse() : node_from_camera;
  }

  void insert(const PoseEdge& edge, const std::string& label) {
    const std::size_t camera = node_of_.at(label);
    graph_.insertEdge(edge.from_camera ? camera : edge.node, edge.from_camera ? edge.node : camera,
                      toMrptPosePdf(edge.first_from_second, edge.covariance));
  }

  /// The trajectory pose nearest the camera (the robot passes under it).
  std::size_t nearestPose(const Rigid3d& camera) const {
    std::size_t best = 0;
    double best_distance = std::numeric_limits<double>::infinity();
    for (std::size_t k = 0; k < reg_.trajectory.size(); ++k) {
      const double d = (reg_.trajectory[k].world_from_body.translation - camera.translation).norm();
      if (d < best_distance) {
        best_distance = d;
        best = k;
      }
    }
    return best;
  }

  const ExportContext& context_;
  const Registration& reg_;
  GraphSigmas sigmas_;
  Trajectory trajectory_;
  mrpt::graphs::CNetworkOfPoses3DCov graph_;
  std::map<std::string, std::size_t> node_of_;
  std::map<std::string, int> marker_edges_;
  int blob_edges_ = 0, covariance_edges_ = 0, markers_left_out_ = 0;
};

std::string graphText(const ExportContext& context, std::string* summary) {
  GraphBuilder builder(context);
  builder.addTrajectory();
  builder.addCameraNodes();
  builder.addMarkerEdges();
  builder.addBlobEdges();
  builder.addCovarianceEdges();
  *summary = builder.summary();
  std::ostringstream text;
  text.precision(17);  // MRPT writes through the stream: all the digits of a double
  builder.graph().writeAsText(text);
  return text.str();
}

}  // namespace

void writeMrpt(const ExportContext& context) {
  const Registration& reg = context.registration;
  if (reg.trajectory.empty()) {
    throw Error(
        "export mrpt: the registration has no trajectory (trajectory.tum) to make "
        "the graph's nodes");
  }
  std::string summary;
  context.write("registration.graph", graphText(context, &summary));
  context.result->notes.push_back(summary);
  std::ostringstream pdfs;
  pdfs << "# label x y z yaw pitch roll [m, rad], then the 6x6 covariance over them, rows first\n";
  // Each camera's pose PDF also as MRPT observations (cameras.rawlog:
  // uncompressed, which MRPT reads as it reads gzip), stamped with the
  // drive's end, the registration's time.
  mrpt::io::CMemoryStream rawlog;
  auto archive = mrpt::serialization::archiveFrom(rawlog);
  for (const ExportedCamera& c : context.cameras) {
    const CameraRegistration& camera = *c.registration;
    const Matrix6d covariance = camera.covariance.value_or(Matrix6d::Identity() * 1e-4);
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
  }
  context.write("cameras_pdf.txt", pdfs.str());
  const auto* bytes = static_cast<const char*>(rawlog.getRawBufferData());
  context.write("cameras.rawlog", std::string(bytes, bytes + rawlog.getTotalBytesCount()));
}

}  // namespace lookboth::export_detail
