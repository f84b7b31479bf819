// Each export read back by its consumer's own reader where one is at hand
// (OpenCV's FileStorage, a JSON parser) or by the format's definition
// (COLMAP's cam_from_world, URDF's fixed-axis roll-pitch-yaw).
#include <gtest/gtest.h>
#include <unistd.h>

#include <mrpt/graphs/CNetworkOfPoses.h>
#include <mrpt/graphslam/levmarq.h>
#include <mrpt/io/CFileInputStream.h>
#include <mrpt/obs/CObservationRobotPose.h>
#include <mrpt/serialization/CArchive.h>
#include <Eigen/Core>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/core/eigen.hpp>
#include <regex>
#include <set>
#include <sstream>

#include "../src/graph_edges.h"
#include "lookboth/core/atomic_file.h"
#include "lookboth/core/error.h"
#include "lookboth/export/export.h"
#include "lookboth/geometry/lie.h"
#include "lookboth/geometry/pose_conversions.h"

namespace lookboth {
namespace {

Rigid3d pose(double ax, double ay, double az, const Eigen::Vector3d& t) {
  const Eigen::Quaterniond q = Eigen::AngleAxisd(az, Eigen::Vector3d::UnitZ()) *
                               Eigen::AngleAxisd(ay, Eigen::Vector3d::UnitY()) *
                               Eigen::AngleAxisd(ax, Eigen::Vector3d::UnitX());
  return Rigid3d(q, t);
}

CameraRegistration camera(const std::string& label, CameraStatus status, const Rigid3d& p) {
  CameraRegistration c;
  c.label = label;
  c.status = status;
  c.world_from_camera = p;
  Matrix6d covariance = Matrix6d::Zero();
  for (int i = 0; i < 6; ++i) {
    for (int j = 0; j < 6; ++j) covariance(i, j) = 1e-6 * (i == j ? 2.0 + i : 0.1 * (i + j));
  }
  c.covariance = covariance;
  return c;
}

struct Fixture {
  Registration reg;
  ExportSources sources;
  Fixture() {
    reg.dataset = "/data/site.rawlog";
    reg.created = "2026-11-26T12:00:00Z";
    reg.cameras = {
        camera("cam_a", CameraStatus::kRegistered, pose(3.1, 0.02, 0.7, {1.5, -2.25, 3.1})),
        camera("cam_b", CameraStatus::kRegistered, pose(-3.0, -0.1, -2.9, {-4.0, 6.5, 2.9})),
        camera("cam_c", CameraStatus::kSuspect, pose(3.0, 0.05, 1.9, {0.25, 0.5, 3.3})),
        camera("cam_d", CameraStatus::kUnregistered, Rigid3d())};
    for (int k = 0; k < 50; ++k) {
      reg.trajectory.push_back(
          {k * 100000000LL, pose(0.01 * k, -0.02, 0.1 * k, {0.2 * k, 0.05 * k * k / 50, 0.4})});
    }
    sources.intrinsics.emplace("cam_a", Camera(PinholeModel{}, 640, 480, {500, 501, 320, 240}));
    sources.intrinsics.emplace(
        "cam_b",
        Camera(RadTanModel{}, 1920, 1080, {1000, 1001, 960, 540, -0.1, 0.02, 1e-4, -2e-4, 0.003}));
    sources.intrinsics.emplace(
        "cam_c", Camera(DoubleSphereModel{}, 1920, 1080, {477.0, 477.0, 959.5, 539.5, -0.2, 0.6}));
  }
};

std::filesystem::path freshFolder(const std::string& name) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("export_" + name + "_" + std::to_string(getpid()));
  std::filesystem::remove_all(dir);
  return dir;
}

ExportResult run(const Fixture& f, ExportFormat format, const std::filesystem::path& dir,
                 bool include_suspect = false) {
  ExportOptions options;
  options.format = format;
  options.include_suspect = include_suspect;
  return exportRegistration(f.reg, f.sources, dir, options);
}

std::vector<std::string> dataLines(const std::filesystem::path& path) {
  std::istringstream in(readFile(path));
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] != '#') lines.push_back(line);
  }
  return lines;
}

TEST(Export, ColmapImagesHoldEachCamerasCamFromWorld) {
  const Fixture f;
  const std::filesystem::path dir = freshFolder("colmap");
  const ExportResult result = run(f, ExportFormat::kColmap, dir);
  EXPECT_EQ(result.cameras, 2);  // the suspect and the unregistered left out
  const std::vector<std::string> cameras = dataLines(dir / "cameras.txt");
  ASSERT_EQ(cameras.size(), 2u);
  EXPECT_EQ(cameras[0], "1 PINHOLE 640 480 500 501 320 240");
  EXPECT_EQ(cameras[1],
            "2 FULL_OPENCV 1920 1080 1000 1001 960 540 -0.1 0.02 1e-04 -2e-04 0.003 0 0 0");
  std::istringstream images(readFile(dir / "images.txt"));
  std::vector<std::string> rows;
  for (std::string line; std::getline(images, line);) {
    if (!line.empty() && line[0] == '#') continue;
    rows.push_back(line);
  }
  ASSERT_EQ(rows.size(), 4u);  // an image line, then its (empty) 2-D points line
  for (int i = 0; i < 2; ++i) {
    std::istringstream row(rows[2 * i]);
    int id = 0, camera_id = 0;
    double qw, qx, qy, qz, tx, ty, tz;
    std::string name;
    row >> id >> qw >> qx >> qy >> qz >> tx >> ty >> tz >> camera_id >> name;
    EXPECT_EQ(id, i + 1);
    EXPECT_EQ(camera_id, i + 1);
    EXPECT_EQ(name, f.reg.cameras[i].label);
    EXPECT_TRUE(rows[2 * i + 1].empty());
    // cam_from_world maps the camera's centre in the world to the origin.
    const Eigen::Quaterniond q(qw, qx, qy, qz);
    const Eigen::Vector3d centre = f.reg.cameras[i].world_from_camera.translation;
    EXPECT_LT((q * centre + Eigen::Vector3d(tx, ty, tz)).norm(), 1e-12);
    EXPECT_LT((q.toRotationMatrix().transpose() -
               f.reg.cameras[i].world_from_camera.rotation.toRotationMatrix())
                  .norm(),
              1e-14);
  }
  EXPECT_EQ(dataLines(dir / "points3D.txt").size(), 0u);
}

TEST(Export, ColmapRefusesAModelItHasNotNamingTheCamera) {
  const Fixture f;
  try {
    run(f, ExportFormat::kColmap, freshFolder("colmap_ds"), true);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("'cam_c'"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("double_sphere"), std::string::npos) << e.what();
  }
}

TEST(Export, JsonHoldsPosesCovariancesAndIntrinsics) {
  const Fixture f;
  const std::filesystem::path dir = freshFolder("json");
  run(f, ExportFormat::kJson, dir, true);
  const auto root = nlohmann::json::parse(readFile(dir / "registration.json"));
  EXPECT_EQ(root["format"], "lookboth.registration_export");
  ASSERT_EQ(root["cameras"].size(), 3u);
  for (int i = 0; i < 3; ++i) {
    const auto& c = root["cameras"][i];
    const CameraRegistration& truth = f.reg.cameras[i];
    EXPECT_EQ(c["label"], truth.label);
    EXPECT_EQ(c["status"], cameraStatusName(truth.status));
    const auto& t = c["world_from_camera"]["translation"];
    EXPECT_EQ(t["x"].get<double>(), truth.world_from_camera.translation.x());
    EXPECT_EQ(t["z"].get<double>(), truth.world_from_camera.translation.z());
    const auto& q = c["world_from_camera"]["rotation"];
    EXPECT_EQ(q["qw"].get<double>(), truth.world_from_camera.rotation.w());
    const Eigen::Matrix4d m = truth.world_from_camera.matrix();
    EXPECT_EQ(c["world_from_camera"]["matrix"][1][2].get<double>(), m(1, 2));
    ASSERT_EQ(c["covariance"].size(), 36u);
    EXPECT_EQ(c["covariance"][6 * 2 + 4].get<double>(), (*truth.covariance)(2, 4));
    EXPECT_TRUE(c["aligned_position_covariance"].is_null());
  }
  const auto& ds = root["cameras"][2]["intrinsics"];
  EXPECT_EQ(ds["model"], "double_sphere");
  EXPECT_EQ(ds["params"]["alpha"].get<double>(), 0.6);
}

TEST(Export, OpenCvFilesReadBackWithFileStorage) {
  const Fixture f;
  const std::filesystem::path dir = freshFolder("opencv");
  const ExportResult result = run(f, ExportFormat::kOpenCv, dir);
  ASSERT_EQ(result.files.size(), 2u);
  cv::FileStorage fs((dir / "cam_b.yaml").string(), cv::FileStorage::READ);
  ASSERT_TRUE(fs.isOpened());
  EXPECT_EQ(static_cast<std::string>(fs["camera"]), "cam_b");
  EXPECT_EQ(static_cast<int>(fs["image_width"]), 1920);
  cv::Mat pose, covariance, k, distortion;
  fs["world_from_camera"] >> pose;
  fs["covariance"] >> covariance;
  fs["camera_matrix"] >> k;
  fs["distortion_coefficients"] >> distortion;
  Eigen::Matrix4d pose_e;
  cv::cv2eigen(pose, pose_e);
  EXPECT_EQ(pose_e, f.reg.cameras[1].world_from_camera.matrix());
  Matrix6d covariance_e;
  cv::cv2eigen(covariance, covariance_e);
  EXPECT_EQ(covariance_e, *f.reg.cameras[1].covariance);
  EXPECT_EQ(k.at<double>(0, 2), 960.0);
  ASSERT_EQ(distortion.total(), 5u);
  EXPECT_EQ(distortion.at<double>(0, 4), 0.003);
}

TEST(Export, UrdfRollPitchYawRebuildsTheRotation) {
  for (const Eigen::Vector3d& axis_angle :
       {Eigen::Vector3d(3.1, 0.02, 0.7), Eigen::Vector3d(-0.4, 1.2, -2.9),
        Eigen::Vector3d(0.3, -0.25, 3.0), Eigen::Vector3d(0, 0, 0)}) {
    const Eigen::Matrix3d r =
        Eigen::AngleAxisd(axis_angle.norm(), axis_angle.normalized()).toRotationMatrix();
    const Eigen::Vector3d rpy =
        rollPitchYaw(axis_angle.norm() > 0 ? r : Eigen::Matrix3d::Identity());
    const Eigen::Matrix3d rebuilt = (Eigen::AngleAxisd(rpy.z(), Eigen::Vector3d::UnitZ()) *
                                     Eigen::AngleAxisd(rpy.y(), Eigen::Vector3d::UnitY()) *
                                     Eigen::AngleAxisd(rpy.x(), Eigen::Vector3d::UnitX()))
                                        .toRotationMatrix();
    EXPECT_LT((rebuilt - (axis_angle.norm() > 0 ? r : Eigen::Matrix3d::Identity())).norm(), 1e-14);
  }
  // Pitch at 90 degrees: roll and yaw share an axis, the rotation is kept.
  const Eigen::Matrix3d locked = (Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitZ()) *
                                  Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitY()))
                                     .toRotationMatrix();
  const Eigen::Vector3d rpy = rollPitchYaw(locked);
  const Eigen::Matrix3d rebuilt = (Eigen::AngleAxisd(rpy.z(), Eigen::Vector3d::UnitZ()) *
                                   Eigen::AngleAxisd(rpy.y(), Eigen::Vector3d::UnitY()) *
                                   Eigen::AngleAxisd(rpy.x(), Eigen::Vector3d::UnitX()))
                                      .toRotationMatrix();
  EXPECT_LT((rebuilt - locked).norm(), 1e-12);
}

TEST(Export, RosUrdfJointsGiveEachCamerasPose) {
  const Fixture f;
  const std::filesystem::path dir = freshFolder("ros");
  const ExportResult result = run(f, ExportFormat::kRos, dir, true);
  const std::string urdf = readFile(dir / "site.urdf");
  const std::regex origin(
      "<child link=\"(\\w+)_optical_frame\"/>\\s*<origin xyz=\"(\\S+) (\\S+) (\\S+)\" "
      "rpy=\"(\\S+) (\\S+) (\\S+)\"/>");
  int joints = 0;
  for (auto it = std::sregex_iterator(urdf.begin(), urdf.end(), origin);
       it != std::sregex_iterator(); ++it, ++joints) {
    const std::smatch& m = *it;
    const CameraRegistration* truth = f.reg.findCamera(m[1]);
    ASSERT_NE(truth, nullptr) << m[1];
    const Eigen::Vector3d xyz(std::stod(m[2]), std::stod(m[3]), std::stod(m[4]));
    EXPECT_EQ(xyz, truth->world_from_camera.translation);
    const Eigen::Matrix3d r = (Eigen::AngleAxisd(std::stod(m[7]), Eigen::Vector3d::UnitZ()) *
                               Eigen::AngleAxisd(std::stod(m[6]), Eigen::Vector3d::UnitY()) *
                               Eigen::AngleAxisd(std::stod(m[5]), Eigen::Vector3d::UnitX()))
                                  .toRotationMatrix();
    EXPECT_LT((r - truth->world_from_camera.rotation.toRotationMatrix()).norm(), 1e-13);
  }
  EXPECT_EQ(joints, 3);
  EXPECT_TRUE(std::filesystem::exists(dir / "camera_info/cam_b_optical_frame.yaml"));
  EXPECT_FALSE(std::filesystem::exists(dir / "camera_info/cam_c_optical_frame.yaml"));
  ASSERT_EQ(result.notes.size(), 1u);
  EXPECT_NE(result.notes[0].find("cam_c"), std::string::npos);
  EXPECT_NE(readFile(dir / "static_transforms.launch.py")
                .find("'--child-frame-id', 'cam_b_optical_frame'"),
            std::string::npos);
}

TEST(Export, MrptGraphReadsBackAndIsConsistent) {
  const Fixture f;
  const std::filesystem::path dir = freshFolder("mrpt");
  run(f, ExportFormat::kMrpt, dir, true);
  mrpt::graphs::CNetworkOfPoses3DCov graph;
  graph.loadFromTextFile((dir / "registration.graph").string());
  ASSERT_EQ(graph.nodes.size(), f.reg.trajectory.size() + 3);  // cam_a, cam_b, cam_c
  EXPECT_EQ(graph.edges.size(), f.reg.trajectory.size() - 1 + 3);
  const Rigid3d camera = fromMrptPose(graph.nodes.at(f.reg.trajectory.size() + 1));
  EXPECT_LT((camera.translation - f.reg.cameras[1].world_from_camera.translation).norm(), 1e-9);
  // Every edge is its nodes' relative pose: the graph is at its optimum.
  for (const auto& [ids, edge] : graph.edges) {
    const Rigid3d a = fromMrptPose(graph.nodes.at(ids.first));
    const Rigid3d b = fromMrptPose(graph.nodes.at(ids.second));
    const Rigid3d relative = a.inverse() * b;
    EXPECT_LT((fromMrptPose(edge.mean).translation - relative.translation).norm(), 1e-9);
    EXPECT_GT(edge.cov(0, 0), 0.0);
  }
  // At an identity rotation a right perturbation is (roll, pitch, yaw) itself.
  Fixture g;
  g.reg.cameras[0].world_from_camera = Rigid3d(Eigen::Quaterniond::Identity(), {1, 2, 3});
  Matrix6d covariance = Matrix6d::Zero();
  covariance.diagonal() << 1, 2, 3, 4e-4, 5e-4, 6e-4;
  g.reg.cameras[0].covariance = covariance;
  const std::filesystem::path dir2 = freshFolder("mrpt_identity");
  run(g, ExportFormat::kMrpt, dir2);
  std::istringstream pdfs(readFile(dir2 / "cameras_pdf.txt"));
  std::string line;
  std::getline(pdfs, line);  // header
  std::getline(pdfs, line);
  std::istringstream row(line);
  std::string label;
  row >> label;
  std::vector<double> v(6 + 36);
  for (double& x : v) row >> x;
  EXPECT_EQ(label, "cam_a");
  EXPECT_NEAR(v[6 + 3 * 6 + 3], 6e-4, 1e-12);  // yaw <- dtheta_z
  EXPECT_NEAR(v[6 + 4 * 6 + 4], 5e-4, 1e-12);  // pitch <- dtheta_y
  EXPECT_NEAR(v[6 + 5 * 6 + 5], 4e-4, 1e-12);  // roll <- dtheta_x
  EXPECT_NEAR(v[6 + 2 * 6 + 2], 3.0, 1e-12);
  // The same PDF in cameras.rawlog, read back by MRPT.
  mrpt::io::CFileInputStream in((dir2 / "cameras.rawlog").string());
  auto archive = mrpt::serialization::archiveFrom(in);
  const auto first = archive.ReadObject<mrpt::obs::CObservationRobotPose>();
  ASSERT_TRUE(first);
  EXPECT_EQ(first->sensorLabel, "cam_a");
  EXPECT_NEAR(first->pose.mean.x(), 1.0, 1e-12);
  EXPECT_NEAR(first->pose.cov(3, 3), 6e-4, 1e-12);
  EXPECT_NEAR(first->pose.cov(2, 2), 3.0, 1e-12);
}

// A registration with exact detections of the robot's marker (one camera's
// clock 25 ms ahead), exact blobs through a fisheye (the housing 5 cm from
// the optical centre), and what the graph should make of them.
struct DetectedFixture : Fixture {
  int markers = 0, blobs = 0;
  std::set<std::pair<std::string, std::size_t>> marker_nodes;  ///< (camera, trajectory node)
  int blobs_on_marker_nodes = 0;
  DetectedFixture() {
    reg.fisheye_from_marker = pose(0.02, -0.01, 1.5, {0.0, -0.15, -0.05});
    reg.cameras[1].clock_offset = ClockOffsetEstimate{25000000, 1.0, true};
    reg.config_yaml = "joint: {blob_offset_in_camera_m: [0.01, -0.02, 0.05]}\n";
    sources.fisheye = "fisheye";
    sources.intrinsics.emplace("fisheye", Camera(KannalaBrandtModel{}, 1280, 1024,
                                                 {300, 301, 640, 512, 0.01, -0.002, 0, 0}));
    for (int i = 0; i < 3; ++i) addCamera(reg.cameras[static_cast<std::size_t>(i)], i);
  }
  /// The exact detection of the robot's marker by `c` at robot time t.
  MarkerObservation detectionAt(const CameraRegistration& c, TimeNs t) const {
    const Rigid3d world_from_fisheye = Trajectory(reg.trajectory).interpolate(t, 0).world_from_body;
    MarkerObservation m;
    m.t = t + (c.clock_offset ? c.clock_offset->offset_ns : 0);
    m.camera = c.label;
    m.camera_from_marker =
        c.world_from_camera.inverse() * world_from_fisheye * reg.fisheye_from_marker;
    m.information.diagonal() << 1e6, 2e6, 3e5, 1e2, 2e2, 1e4;
    return m;
  }
  void addCamera(const CameraRegistration& c, int i) {
    for (TimeNs t = 150000000 + i * 7000000; t < 4800000000; t += 330000000) {
      sources.marker_detections.push_back(detectionAt(c, t));
      marker_nodes.insert({c.label, export_detail::nearestSample(reg.trajectory, t)});
      ++markers;
    }
    const Camera& fisheye = sources.intrinsics.at("fisheye");
    const Eigen::Vector3d housing = c.world_from_camera * Eigen::Vector3d(0.01, -0.02, 0.05);
    for (std::size_t k = 0; k < reg.trajectory.size(); k += 7) {
      const auto pixel = fisheye.project(reg.trajectory[k].world_from_body.inverse() * housing);
      if (!pixel) continue;
      reg.blob_associations.push_back({reg.trajectory[k].t, c.label, pixel->x(), pixel->y()});
      ++blobs;
      blobs_on_marker_nodes += marker_nodes.count({c.label, k}) ? 1 : 0;
    }
  }
  /// The edges the graph should hold: the odometry's, one per (camera,
  /// node) pair of the detections, one per pair of the blobs without one.
  std::size_t expectedEdges() const {
    return reg.trajectory.size() - 1 + marker_nodes.size() +
           static_cast<std::size_t>(blobs - blobs_on_marker_nodes);
  }
};

double rotationError(const Rigid3d& a, const Rigid3d& b) {
  return so3Log(Eigen::Quaterniond(a.rotation.conjugate() * b.rotation)).norm();
}

/// Every edge of the graph against its nodes' relative pose [m, rad].
std::pair<double, double> worstEdge(const mrpt::graphs::CNetworkOfPoses3DCov& graph) {
  std::pair<double, double> worst{0, 0};
  for (const auto& [ids, edge] : graph.edges) {
    const Rigid3d relative = fromMrptPose(graph.nodes.at(ids.first)).inverse() *
                             fromMrptPose(graph.nodes.at(ids.second));
    const Rigid3d measured = fromMrptPose(edge.mean);
    worst.first = std::max(worst.first, (measured.translation - relative.translation).norm());
    worst.second = std::max(worst.second, rotationError(measured, relative));
  }
  return worst;
}

TEST(Export, MrptGraphEdgesAreTheDetectionsAndBlobs) {
  DetectedFixture f;
  ASSERT_GT(f.blobs - f.blobs_on_marker_nodes, 10);
  ASSERT_GT(f.blobs_on_marker_nodes, 0);
  // One detection half a metre off: left out, and said so. Another at the
  // same node as one of cam_a's: fused with it into one edge.
  MarkerObservation off = f.sources.marker_detections[3];
  off.t += 1000;
  off.camera_from_marker.translation.x() += 0.5;
  MarkerObservation again = f.detectionAt(f.reg.cameras[0], 1830000000);  // cam_a's 1.80 s: node 18
  again.information *= 3;
  f.sources.marker_detections.push_back(off);
  f.sources.marker_detections.push_back(again);
  const std::filesystem::path dir = freshFolder("mrpt_edges");
  const ExportResult result = run(f, ExportFormat::kMrpt, dir, true);
  ASSERT_EQ(result.notes.size(), 1u);
  EXPECT_EQ(result.notes[0],
            "registration.graph: " + std::to_string(f.markers + 1) + " marker detections in " +
                std::to_string(f.marker_nodes.size()) + " edges, " + std::to_string(f.blobs) +
                " blobs in " + std::to_string(f.blobs - f.blobs_on_marker_nodes) +
                " (the others on a marker edge's nodes), 0 registered-covariance edges; 1 "
                "marker detections left out, more than 10 sigmas from the registration");
  // Every edge as written: one per pair of nodes, which MRPT's loader keeps.
  mrpt::graphs::CNetworkOfPoses3DCov graph;
  graph.loadFromTextFile((dir / "registration.graph").string(), false);
  ASSERT_EQ(graph.edges.size(), f.expectedEdges());
  mrpt::graphs::CNetworkOfPoses3DCov collapsed;
  collapsed.loadFromTextFile((dir / "registration.graph").string());
  EXPECT_EQ(collapsed.edges.size(), graph.edges.size());
  const auto [translation, rotation] = worstEdge(graph);
  EXPECT_LT(translation, 1e-9);  // blob_offset_in_camera_m ignored: 5 cm
  EXPECT_LT(rotation, 1e-9);
  int from_camera = 0;
  for (const auto& [ids, edge] : graph.edges) from_camera += ids.first >= f.reg.trajectory.size();
  EXPECT_EQ(static_cast<std::size_t>(from_camera), f.marker_nodes.size());
}

// MRPT's own optimiser, given the graph's edges with their information,
// brings cameras moved off their registered poses back to them.
TEST(Export, MrptsOptimiserRecoversTheCamerasFromTheEdges) {
  const DetectedFixture f;
  const std::filesystem::path dir = freshFolder("mrpt_levmarq");
  run(f, ExportFormat::kMrpt, dir, true);
  mrpt::graphs::CNetworkOfPoses3DInf graph;
  graph.loadFromTextFile((dir / "registration.graph").string());
  const std::size_t n = f.reg.trajectory.size();
  std::set<mrpt::graphs::TNodeID> cameras;
  for (std::size_t id = n; id < graph.nodes.size(); ++id) {
    cameras.insert(id);
    const Rigid3d moved = fromMrptPose(graph.nodes.at(id)) *
                          pose(0.01, -0.02, 0.015, Eigen::Vector3d(0.05, -0.03, 0.04));
    graph.nodes.at(id) = toMrptPose(moved);
  }
  mrpt::graphslam::TResultInfoSpaLevMarq info;
  mrpt::containers::yaml parameters;
  parameters["max_iterations"] = 50;
  mrpt::graphslam::optimize_graph_spa_levmarq(graph, info, &cameras, parameters);
  for (std::size_t id = n; id < graph.nodes.size(); ++id) {
    const Rigid3d& registered = f.reg.cameras[id - n].world_from_camera;
    const Rigid3d recovered = fromMrptPose(graph.nodes.at(id));
    EXPECT_LT((recovered.translation - registered.translation).norm(), 1e-6) << id;
    EXPECT_LT(rotationError(recovered, registered), 1e-6) << id;
  }
}

TEST(Export, MrptGraphKeepsTheCovarianceEdgeOfACameraWithoutDetections) {
  DetectedFixture f;
  f.sources.marker_detections.clear();
  const std::filesystem::path dir = freshFolder("mrpt_no_markers");
  const ExportResult result = run(f, ExportFormat::kMrpt, dir, true);
  EXPECT_EQ(result.notes.at(0), "registration.graph: 0 marker detections in 0 edges, " +
                                    std::to_string(f.blobs) + " blobs in " +
                                    std::to_string(f.blobs) +
                                    " (the others on a marker edge's nodes), 3 "
                                    "registered-covariance edges");
}

TEST(GraphEdges, ADetectionsCovarianceFollowsTheCompositionToFirstOrder) {
  const Rigid3d camera_from_marker = pose(2.9, 0.1, -0.4, {0.2, -0.3, 3.1});
  const Rigid3d marker_from_node = pose(0.3, -0.2, 1.1, {0.5, -1, 0.2});
  const Rigid3d composed = camera_from_marker * marker_from_node;
  const double h = 1e-7;
  for (int i = 0; i < 6; ++i) {
    Eigen::Matrix<double, 6, 1> d = Eigen::Matrix<double, 6, 1>::Zero();
    d(i) = h;
    const Rigid3d moved(camera_from_marker.rotation * so3Exp(Eigen::Vector3d(d.tail<3>())),
                        camera_from_marker.translation + d.head<3>());
    const Rigid3d composed_moved = moved * marker_from_node;
    Eigen::Matrix<double, 6, 1> column;
    column.head<3>() = (composed_moved.translation - composed.translation) / h;
    column.tail<3>() =
        so3Log(Eigen::Quaterniond(composed.rotation.conjugate() * composed_moved.rotation)) / h;
    Matrix6d unit = Matrix6d::Zero();
    unit(i, i) = 1;
    const Matrix6d covariance =
        export_detail::composedCovariance(camera_from_marker, marker_from_node, unit);
    EXPECT_LT((covariance - column * column.transpose()).norm(), 1e-6) << "component " << i;
  }
}

TEST(GraphEdges, ABlobIsABearingLooseAlongItsRayAndInRotation) {
  // The fisheye at the origin, the camera's housing 3 m straight above it:
  // seen at the principal point, where the model's scale is f (300 px/rad).
  const Trajectory trajectory({{0, Rigid3d()}, {100000000, Rigid3d()}});
  const Camera fisheye(KannalaBrandtModel{}, 1280, 1024, {300, 300, 640, 512, 0.01, 0, 0, 0});
  export_detail::EdgeModel model;
  model.blob_sigma_px = 2.0;
  model.blob_in_camera = Eigen::Vector3d(0, 0, 0.05);
  const Rigid3d world_from_camera = pose(3.1, 0.0, 0.3, {0.01, 0.02, 3});
  const Eigen::Vector3d housing = world_from_camera * model.blob_in_camera;
  const BlobAssociation blob{50000000, "cam", 640 + 300 * housing.x() / housing.z(),
                             512 + 300 * housing.y() / housing.z()};
  const auto edge = export_detail::blobEdge(trajectory, blob, fisheye, world_from_camera, model);
  ASSERT_TRUE(edge);
  EXPECT_LT((edge->first_from_second.translation - world_from_camera.translation).norm(), 1e-4);
  EXPECT_LT(rotationError(edge->first_from_second, world_from_camera), 1e-12);
  // Across the ray range * sigma_px / f, along it loose.
  const double sideways = housing.norm() * 2.0 / 300;
  const Eigen::Vector3d ray = housing.normalized();
  const Eigen::Matrix3d translation = edge->covariance.topLeftCorner<3, 3>();
  for (const Eigen::Vector3d& across : {ray.cross(Eigen::Vector3d::UnitX()).normalized(),
                                        ray.cross(Eigen::Vector3d::UnitY()).normalized()}) {
    EXPECT_NEAR(across.dot(translation * across), sideways * sideways, 1e-3 * sideways * sideways);
  }
  EXPECT_NEAR(ray.dot(translation * ray), 100, 1e-6);
  EXPECT_NEAR(edge->covariance(4, 4), 100, 1e-12);
  // A pixel that maps to no ray gives no edge.
  const Camera narrow(PinholeModel{}, 640, 480, {500, 500, 320, 240});
  const BlobAssociation behind{50000000, "cam", 1e9, 1e9};
  EXPECT_FALSE(export_detail::blobEdge(trajectory, behind, narrow, world_from_camera, model));
}

TEST(GraphEdges, PassesEndAtAGapAndInflateBySharedError) {
  const TimeNs s = 1000000000;
  EXPECT_EQ(export_detail::passSizes({0, s / 2, 2 * s, 2 * s + 4 * s / 10, 2 * s + 8 * s / 10}, s),
            (std::vector<int>{2, 2, 3, 3, 3}));
  EXPECT_TRUE(export_detail::passSizes({}, s).empty());
  EXPECT_DOUBLE_EQ(export_detail::passInflation(1, 0.15), 1.0);
  EXPECT_DOUBLE_EQ(export_detail::passInflation(21, 0.15), 4.0);
}

// Two edges of one pair as one: the information-weighted mean, the
// information summed.
TEST(GraphEdges, EdgesOfOnePairFuseByTheirInformation) {
  export_detail::PoseEdge a, b;
  a.first_from_second = pose(0.1, 0.2, 0.3, {1, 2, 3});
  b.first_from_second = Rigid3d(a.first_from_second.rotation * so3Exp(Eigen::Vector3d(0, 0, 0.003)),
                                a.first_from_second.translation + Eigen::Vector3d(0.03, 0, 0));
  a.covariance = Matrix6d::Identity() * 1e-4;
  b.covariance = Matrix6d::Identity() * 3e-4;
  const export_detail::PoseEdge fused = export_detail::fuseEdges({a, b});
  EXPECT_NEAR((fused.first_from_second.translation - a.first_from_second.translation).x(),
              0.03 * 0.25, 1e-12);
  EXPECT_NEAR(rotationError(a.first_from_second, fused.first_from_second), 0.003 * 0.25, 1e-9);
  EXPECT_LT((fused.covariance - Matrix6d::Identity() * 0.75e-4).norm(), 1e-15);
}

TEST(Export, NothingToExportIsAnError) {
  Fixture f;
  for (CameraRegistration& c : f.reg.cameras) c.status = CameraStatus::kUnregistered;
  EXPECT_THROW(run(f, ExportFormat::kJson, freshFolder("empty")), Error);
  ExportOptions options;
  options.world_frame = "site frame";
  EXPECT_NE(options.check().find("world_frame"), std::string::npos);
}

}  // namespace
}  // namespace lookboth
