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
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <set>
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

/// What the registration weighted its inputs with, as it ran (its
/// configuration, the drift factors it estimated).
struct GraphSettings {
  double m_per_sqrt_m = 0.01, deg_per_sqrt_m = 0.2, min_m = 0.0005, min_deg = 0.005;
  double default_m = 0.01, default_deg = 2.0;  ///< A detection without an information matrix.
  EdgeModel edges;
  std::map<std::string, std::int64_t> configured_offsets_ns;  ///< associate.clock_offsets_ns
  /// The share of a detection's (a blob's) error its pass shares, and the
  /// gap that ends a pass (joint's pass_error_share, blob_pass_error_share,
  /// pass_gap_s).
  double pass_share = 0.15, blob_pass_share = 0.06;
  TimeNs pass_gap_ns = 1'000'000'000;
};

double readDouble(const YAML::Node& section, const char* key, double fallback) {
  return section && section[key] ? section[key].as<double>() : fallback;
}

void readJoint(const YAML::Node& joint, GraphSettings& s) {
  s.m_per_sqrt_m = readDouble(joint, "drift_m_per_sqrt_m", s.m_per_sqrt_m);
  s.deg_per_sqrt_m = readDouble(joint, "drift_deg_per_sqrt_m", s.deg_per_sqrt_m);
  s.min_m = readDouble(joint, "min_sigma_m", s.min_m);
  s.min_deg = readDouble(joint, "min_sigma_deg", s.min_deg);
  s.default_m = readDouble(joint, "default_translation_sigma_m", s.default_m);
  s.default_deg = readDouble(joint, "default_rotation_sigma_deg", s.default_deg);
  s.edges.blob_sigma_px = readDouble(joint, "blob_sigma_px", s.edges.blob_sigma_px);
  s.pass_share = readDouble(joint, "pass_error_share", s.pass_share);
  s.blob_pass_share = readDouble(joint, "blob_pass_error_share", s.blob_pass_share);
  s.pass_gap_ns = static_cast<TimeNs>(std::llround(readDouble(joint, "pass_gap_s", 1.0) * 1e9));
  if (joint && joint["blob_offset_in_camera_m"] && joint["blob_offset_in_camera_m"].size() == 3) {
    for (int i = 0; i < 3; ++i) {
      s.edges.blob_in_camera[i] = joint["blob_offset_in_camera_m"][i].as<double>();
    }
  }
}

void readAssociate(const YAML::Node& associate, GraphSettings& s) {
  s.edges.max_gap_ns =
      static_cast<TimeNs>(std::llround(readDouble(associate, "max_gap_s", 0.5) * 1e9));
  if (associate && associate["clock_offsets_ns"] && associate["clock_offsets_ns"].IsMap()) {
    for (const auto& entry : associate["clock_offsets_ns"]) {
      s.configured_offsets_ns[entry.first.as<std::string>()] = entry.second.as<std::int64_t>();
    }
  }
}

Matrix6d diagonalCovariance(double sigma_m, double sigma_rad) {
  Matrix6d covariance = Matrix6d::Zero();
  covariance.diagonal() << sigma_m * sigma_m, sigma_m * sigma_m, sigma_m * sigma_m,
      sigma_rad * sigma_rad, sigma_rad * sigma_rad, sigma_rad * sigma_rad;
  return covariance;
}

GraphSettings graphSettings(const Registration& reg) {
  GraphSettings s;
  try {
    const YAML::Node config = YAML::Load(reg.config_yaml);
    if (config.IsMap()) {
      readJoint(config["joint"], s);
      readAssociate(config["associate"], s);
    }
  } catch (const YAML::Exception&) {
    // The defaults above: the configuration is what register wrote.
  }
  if (const auto& drift = reg.observability.drift_model) {
    s.m_per_sqrt_m *= drift->horizontal;
    s.deg_per_sqrt_m *= drift->yaw;
  }
  s.edges.fisheye_from_marker = reg.fisheye_from_marker;
  s.edges.default_detection_covariance =
      diagonalCovariance(s.default_m, s.default_deg * M_PI / 180);
  return s;
}

Matrix6d motionCovariance(const GraphSettings& s, double distance_m) {
  const double t = std::max(s.min_m, s.m_per_sqrt_m * std::sqrt(distance_m));
  const double r = std::max(s.min_deg, s.deg_per_sqrt_m * std::sqrt(distance_m)) * M_PI / 180;
  return diagonalCovariance(t, r);
}

/// Squared Mahalanobis distance beyond which a marker detection is left out
/// of the graph: 10 sigmas, an outlier by any measure (the registration set
/// it aside; MRPT's graph optimisers have no robust loss to do so).
constexpr double kMarkerEdgeGateChi2 = 100;

/// A pair of nodes: the camera's and the trajectory's.
using NodePair = std::pair<std::size_t, std::size_t>;

/// Builds the graph step by step: the trajectory, the cameras, the edges of
/// their measurements, then one edge per pair of nodes (MRPT keeps one).
class GraphBuilder {
 public:
  explicit GraphBuilder(const ExportContext& context)
      : context_(context),
        reg_(context.registration),
        settings_(graphSettings(reg_)),
        trajectory_(reg_.trajectory) {
    graph_.root = 0;
    settings_.edges.max_gap_ns = effectiveMaxGap(trajectory_, settings_.edges.max_gap_ns);
  }

  void addTrajectory() {
    for (std::size_t k = 0; k < reg_.trajectory.size(); ++k) {
      graph_.nodes[k] = toMrptPose(reg_.trajectory[k].world_from_body);
      if (k == 0) continue;
      const Rigid3d relative =
          reg_.trajectory[k - 1].world_from_body.inverse() * reg_.trajectory[k].world_from_body;
      graph_.insertEdge(
          k - 1, k,
          toMrptPosePdf(relative, motionCovariance(settings_, relative.translation.norm())));
    }
  }

  void addCameraNodes() {
    std::size_t id = reg_.trajectory.size();
    for (const ExportedCamera& c : context_.cameras) {
      graph_.nodes[id] = toMrptPose(c.registration->world_from_camera);
      node_of_[c.registration->label] = id++;
    }
  }

  void collectMarkerEdges() {
    for (const auto& [label, detections] : byCamera(context_.sources.marker_detections)) {
      const CameraRegistration& camera = *reg_.findCamera(label);
      std::vector<TimeNs> times;
      for (const MarkerObservation* d : detections) times.push_back(d->t);
      const std::vector<int> passes = passSizes(times, settings_.pass_gap_ns);
      for (std::size_t i = 0; i < detections.size(); ++i) {
        std::optional<PoseEdge> edge =
            markerEdge(trajectory_, *detections[i], clockOffset(camera), settings_.edges);
        if (!edge) continue;
        edge->covariance *= passInflation(passes[i], settings_.pass_share);
        if (edgeChi2(*edge, registeredRelative(*edge, camera)) > kMarkerEdgeGateChi2) {
          ++markers_left_out_;
          continue;
        }
        marker_pairs_[{node_of_.at(label), edge->node}].push_back(*edge);
        ++marker_detections_;
      }
    }
  }

  void collectBlobEdges() {
    const auto fisheye = context_.sources.intrinsics.find(context_.sources.fisheye);
    if (fisheye == context_.sources.intrinsics.end()) return;
    std::map<std::string, std::vector<const BlobAssociation*>> by_camera;
    for (const BlobAssociation& blob : reg_.blob_associations) {
      if (exportedCamera(blob.camera) != nullptr) by_camera[blob.camera].push_back(&blob);
    }
    for (auto& [label, blobs] : by_camera) {
      std::stable_sort(
          blobs.begin(), blobs.end(),
          [](const BlobAssociation* a, const BlobAssociation* b) { return a->t < b->t; });
      std::vector<TimeNs> times;
      for (const BlobAssociation* b : blobs) times.push_back(b->t);
      const std::vector<int> passes = passSizes(times, settings_.pass_gap_ns);
      const Rigid3d& world_from_camera = reg_.findCamera(label)->world_from_camera;
      for (std::size_t i = 0; i < blobs.size(); ++i) {
        std::optional<PoseEdge> edge =
            blobEdge(trajectory_, *blobs[i], fisheye->second, world_from_camera, settings_.edges);
        if (!edge) continue;
        edge->covariance.topLeftCorner<3, 3>() *=
            passInflation(passes[i], settings_.blob_pass_share);
        blob_pairs_[{node_of_.at(label), edge->node}].push_back(*edge);
        ++blobs_;
      }
    }
  }

  /// One edge per pair: a pair's marker edges fused, its blob edges fused
  /// where no marker edge holds it (a bearing adds little to a pose).
  void insertMeasurementEdges() {
    for (const auto& [pair, edges] : marker_pairs_) insert(pair.first, fuseEdges(edges));
    for (const auto& [pair, edges] : blob_pairs_) {
      if (marker_pairs_.count(pair) != 0) continue;
      insert(pair.first, fuseEdges(edges));
      ++blob_edges_;
    }
  }

  /// A camera no detection reached: one edge from the trajectory pose
  /// nearest it, its registered covariance in that pose's frame.
  void addCovarianceEdges() {
    std::set<std::size_t> with_markers;
    for (const auto& [pair, edges] : marker_pairs_) with_markers.insert(pair.first);
    for (const ExportedCamera& c : context_.cameras) {
      const CameraRegistration& camera = *c.registration;
      if (with_markers.count(node_of_.at(camera.label)) != 0) continue;
      const Matrix6d covariance = camera.covariance.value_or(Matrix6d::Identity() * 1e-4);
      const std::size_t k = nearestPose(camera.world_from_camera);
      const Rigid3d& node = reg_.trajectory[k].world_from_body;
      // Translation into the node's frame; the right perturbation of the
      // rotation is unchanged.
      Matrix6d turn = Matrix6d::Identity();
      turn.topLeftCorner<3, 3>() = node.rotation.toRotationMatrix().transpose();
      insert(node_of_.at(camera.label), {k, false, node.inverse() * camera.world_from_camera,
                                         turn * covariance * turn.transpose()});
      ++covariance_edges_;
    }
  }

  const mrpt::graphs::CNetworkOfPoses3DCov& graph() const { return graph_; }

  std::string summary() const {
    std::string text = "registration.graph: " + std::to_string(marker_detections_) +
                       " marker detections in " + std::to_string(marker_pairs_.size()) +
                       " edges, " + std::to_string(blobs_) + " blobs in " +
                       std::to_string(blob_edges_) + " (the others on a marker edge's nodes), " +
                       std::to_string(covariance_edges_) + " registered-covariance edges";
    if (markers_left_out_ > 0) {
      text += "; " + std::to_string(markers_left_out_) +
              " marker detections left out, more than 10 sigmas from the registration";
    }
    return text;
  }

 private:
  /// The exported cameras' detections, each camera's in time order.
  std::map<std::string, std::vector<const MarkerObservation*>> byCamera(
      const std::vector<MarkerObservation>& detections) const {
    std::map<std::string, std::vector<const MarkerObservation*>> result;
    for (const MarkerObservation& d : detections) {
      if (exportedCamera(d.camera) != nullptr) result[d.camera].push_back(&d);
    }
    for (auto& [label, list] : result) {
      std::stable_sort(
          list.begin(), list.end(),
          [](const MarkerObservation* a, const MarkerObservation* b) { return a->t < b->t; });
    }
    return result;
  }

  const CameraRegistration* exportedCamera(const std::string& label) const {
    if (node_of_.count(label) == 0) return nullptr;
    return reg_.findCamera(label);
  }

  /// The camera's clock offset (node - robot): joint's estimate, else the configured one.
  TimeNs clockOffset(const CameraRegistration& camera) const {
    if (camera.clock_offset) return camera.clock_offset->offset_ns;
    const auto configured = settings_.configured_offsets_ns.find(camera.label);
    return configured == settings_.configured_offsets_ns.end() ? 0 : configured->second;
  }

  Rigid3d registeredRelative(const PoseEdge& edge, const CameraRegistration& camera) const {
    const Rigid3d node_from_camera =
        reg_.trajectory[edge.node].world_from_body.inverse() * camera.world_from_camera;
    return edge.from_camera ? node_from_camera.inverse() : node_from_camera;
  }

  void insert(std::size_t camera, const PoseEdge& edge) {
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
  GraphSettings settings_;
  Trajectory trajectory_;
  mrpt::graphs::CNetworkOfPoses3DCov graph_;
  std::map<std::string, std::size_t> node_of_;
  std::map<NodePair, std::vector<PoseEdge>> marker_pairs_, blob_pairs_;
  int marker_detections_ = 0, blobs_ = 0, blob_edges_ = 0, covariance_edges_ = 0;
  int markers_left_out_ = 0;
};

std::string graphText(const ExportContext& context, std::string* summary) {
  GraphBuilder builder(context);
  builder.addTrajectory();
  builder.addCameraNodes();
  builder.collectMarkerEdges();
  builder.collectBlobEdges();
  builder.insertMeasurementEdges();
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
