// simulate(): detections consistent with the ground truth, determinism,
// faults that show up in the output, rendered frames.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <iterator>
#include <opencv2/aruco.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <set>
#include <sstream>

#include "lookboth/core/error.h"
#include "lookboth/core/text.h"
#include "lookboth/geometry/lie.h"
#include "lookboth/geometry/trajectory.h"
#include "lookboth/sim/scenario.h"
#include "lookboth/sim/simulate.h"

namespace lookboth::sim {
namespace {

namespace fs = std::filesystem;
using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Vector6d = Eigen::Matrix<double, 6, 1>;

struct Dataset {
  Manifest manifest;
  std::vector<Record> records;
  std::vector<DatasetIssue> issues;

  template <typename T>
  std::vector<T> all() const {
    std::vector<T> out;
    for (const Record& r : records) {
      if (const T* x = std::get_if<T>(&r)) out.push_back(*x);
    }
    return out;
  }
  Trajectory trajectory(const std::string& label) const {
    Trajectory trajectory;
    for (const PoseSample& p : all<PoseSample>()) {
      if (p.label == label) trajectory.append(p.t, p.world_from_body);
    }
    return trajectory;
  }
};

Dataset readAll(const fs::path& path) {
  Dataset d;
  auto reader = DatasetReader::open(path);
  d.manifest = reader->manifest();
  while (auto record = reader->next()) d.records.push_back(std::move(*record));
  d.issues = reader->issues();
  return d;
}

class SimulateTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("lookboth_simulate_" +
            std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  SimulateSummary run(const std::string& scenario, const fs::path& out, bool detections_only,
                      std::optional<std::uint32_t> seed = std::nullopt, double duration = 0,
                      DatasetKind kind = DatasetKind::kRawlog) {
    SimulateOptions options;
    options.scenario = scenario;
    options.out = out;
    options.kind = kind;
    options.detections_only = detections_only;
    options.seed = seed;
    options.max_duration_s = duration;
    fs::create_directories(out.parent_path());
    return simulate(options, ProgressReporter());
  }

  fs::path dir_;
};

/// Every record as text, full precision: equal text = equal output.
std::string dump(const Dataset& d) {
  std::ostringstream out;
  out << manifestToYaml(d.manifest) << "\n";
  auto pose = [&](const Rigid3d& p) {
    for (int i = 0; i < 3; ++i) out << " " << formatDouble(p.translation[i]);
    for (int i = 0; i < 4; ++i) out << " " << formatDouble(p.rotation.coeffs()[i]);
  };
  for (const Record& r : d.records) {
    out << recordKindName(r) << " " << recordTime(r) << " " << recordLabel(r);
    if (const auto* m = std::get_if<MarkerObservation>(&r)) {
      pose(m->camera_from_marker);
      for (int i = 0; i < 36; ++i) out << " " << formatDouble(m->information.data()[i]);
    } else if (const auto* b = std::get_if<BlobObservation>(&r)) {
      for (const Blob& blob : b->blobs)
        out << " " << formatDouble(blob.u) << "," << formatDouble(blob.v) << ","
            << formatDouble(blob.diameter_px);
    } else if (const auto* p = std::get_if<PoseSample>(&r)) {
      pose(p->world_from_body);
    }
    out << "\n";
  }
  return out.str();
}

/// The error of a marker observation against the truth, as the perturbation
/// [dt; dtheta] with t_true = t + dt, R_true = R Exp(dtheta).
Vector6d markerError(const MarkerObservation& obs, const Rigid3d& truth) {
  Vector6d e;
  e.head<3>() = truth.translation - obs.camera_from_marker.translation;
  e.tail<3>() =
      so3Log(Eigen::Quaterniond(obs.camera_from_marker.rotation.conjugate() * truth.rotation));
  return e;
}

/// The ground truth at t: slerp for the rotation and, for the position,
/// Catmull-Rom through the four samples around t (the robot's path curves
/// between the 10 Hz samples: linear interpolation would be off by ~1 mm).
std::optional<Rigid3d> groundTruthAt(const Trajectory& gt, TimeNs t) {
  const InterpolationResult at = gt.interpolate(t, millisecondsToNs(300));
  if (!at.ok()) return std::nullopt;
  const auto& samples = gt.samples();
  const auto after =
      std::upper_bound(samples.begin(), samples.end(), t,
                       [](TimeNs value, const StampedPose& p) { return value < p.t; });
  if (after == samples.end() || after - samples.begin() < 2 || samples.end() - after < 2)
    return at.world_from_body;
  const size_t i = static_cast<size_t>(after - samples.begin()) - 1;  // samples[i].t <= t
  const Eigen::Vector3d& p0 = samples[i - 1].world_from_body.translation;
  const Eigen::Vector3d& p1 = samples[i].world_from_body.translation;
  const Eigen::Vector3d& p2 = samples[i + 1].world_from_body.translation;
  const Eigen::Vector3d& p3 = samples[i + 2].world_from_body.translation;
  const double u =
      static_cast<double>(t - samples[i].t) / static_cast<double>(samples[i + 1].t - samples[i].t);
  Rigid3d pose = at.world_from_body;
  pose.translation = 0.5 * (2 * p1 + (p2 - p0) * u + (2 * p0 - 5 * p1 + 4 * p2 - p3) * u * u +
                            (-p0 + 3 * p1 - 3 * p2 + p3) * u * u * u);
  return pose;
}

/// The true camera_from_marker of an observation, from the ground truth.
std::optional<Rigid3d> trueCameraFromMarker(const Dataset& d, const Trajectory& gt,
                                            const MarkerObservation& obs) {
  const GroundTruth& truth = d.manifest.ground_truth;
  const TimeNs robot_time = obs.t - truth.clock_offset.at(obs.camera);
  const auto world_from_fisheye = groundTruthAt(gt, robot_time);
  if (!world_from_fisheye) return std::nullopt;
  return truth.world_from_camera.at(obs.camera).inverse() * *world_from_fisheye *
         *truth.fisheye_from_marker;
}

/// RMS per coordinate [px] of ArUco's corners against the true corners, over
/// the environment-camera frames where the marker is in view; and how many.
std::pair<double, int> measuredCornerNoise(const Dataset& d, int refinement_window) {
  const Trajectory gt = d.trajectory("ground_truth");
  const cv::Ptr<cv::aruco::Dictionary> dictionary =
      cv::aruco::getPredefinedDictionary(cv::aruco::DICT_4X4_50);
  const cv::Ptr<cv::aruco::DetectorParameters> parameters = cv::aruco::DetectorParameters::create();
  parameters->cornerRefinementMethod = cv::aruco::CORNER_REFINE_SUBPIX;
  parameters->cornerRefinementWinSize = refinement_window;
  double sum2 = 0;
  int coordinates = 0, markers = 0;
  const double h = 0.5 * d.manifest.marker.size_m;
  const Eigen::Vector3d corners[4] = {{-h, h, 0}, {h, h, 0}, {h, -h, 0}, {-h, -h, 0}};
  for (const ImageFrame& frame : d.all<ImageFrame>()) {
    if (frame.sensor == "fisheye") continue;
    const Camera& camera = *d.manifest.findCamera(frame.sensor)->camera;
    MarkerObservation at;
    at.t = frame.t;
    at.camera = frame.sensor;
    const auto camera_from_marker = trueCameraFromMarker(d, gt, at);
    if (!camera_from_marker) continue;
    std::vector<Eigen::Vector2d> truth;
    for (const Eigen::Vector3d& corner : corners) {
      const auto pixel = camera.project(*camera_from_marker * corner);
      if (pixel && camera.isInImage(*pixel, 3)) truth.push_back(*pixel);
    }
    if (truth.size() != 4) continue;
    const cv::Mat image = cv::imread(frame.image_file.string(), cv::IMREAD_GRAYSCALE);
    std::vector<int> ids;
    std::vector<std::vector<cv::Point2f>> found;
    cv::aruco::detectMarkers(image, dictionary, found, ids, parameters);
    for (size_t k = 0; k < ids.size(); ++k) {
      if (ids[k] != d.manifest.marker.id) continue;
      ++markers;
      for (size_t j = 0; j < 4; ++j) {
        sum2 += (Eigen::Vector2d(found[k][j].x, found[k][j].y) - truth[j]).squaredNorm();
        coordinates += 2;
      }
    }
  }
  return {coordinates ? std::sqrt(sum2 / coordinates) : 0.0, markers};
}

/// RMS per coordinate [px] of plain dark-blob detection in the fisheye
/// frames against the projected optical centres (matches within 4 px).
std::pair<double, int> measuredBlobNoise(const Dataset& d, double min_area) {
  const Trajectory gt = d.trajectory("ground_truth");
  const Camera& fisheye = *d.manifest.fisheye()->camera;
  cv::SimpleBlobDetector::Params params;
  params.filterByColor = true;
  params.blobColor = 0;
  params.minArea = static_cast<float>(min_area);
  params.maxArea = 5000;
  params.filterByCircularity = params.filterByConvexity = params.filterByInertia = false;
  params.minThreshold = 10;
  params.maxThreshold = 120;
  params.thresholdStep = 10;
  const cv::Ptr<cv::SimpleBlobDetector> detector = cv::SimpleBlobDetector::create(params);
  double sum2 = 0;
  int matched = 0;
  for (const ImageFrame& frame : d.all<ImageFrame>()) {
    if (frame.sensor != "fisheye") continue;
    const InterpolationResult at = gt.interpolate(frame.t, 0);
    if (!at.ok()) continue;
    const cv::Mat image = cv::imread(frame.image_file.string(), cv::IMREAD_GRAYSCALE);
    std::vector<cv::KeyPoint> keypoints;
    detector->detect(image, keypoints);
    for (const auto& [label, world_from_camera] : d.manifest.ground_truth.world_from_camera) {
      const auto pixel =
          fisheye.project(at.world_from_body.inverse() * world_from_camera.translation);
      if (!pixel || !fisheye.isInImage(*pixel, 2)) continue;
      double best = 4;
      for (const cv::KeyPoint& k : keypoints)
        best = std::min(best, (Eigen::Vector2d(k.pt.x, k.pt.y) - *pixel).norm());
      if (best < 4) {
        sum2 += best * best;
        ++matched;
      }
    }
  }
  return {matched ? std::sqrt(sum2 / (2 * matched)) : 0.0, matched};
}

TEST_F(SimulateTest, SmallDetectionsOnlyAgreeWithGroundTruth) {
  const fs::path out = dir_ / "small.rawlog";
  const SimulateSummary summary = run("small", out, true);
  EXPECT_EQ(summary.cameras, 6);
  EXPECT_GT(summary.records.at("blobs"), 100);
  EXPECT_GT(summary.records.at("marker"), 50);
  EXPECT_GT(summary.records.at("pose"), 100);
  EXPECT_EQ(summary.records.count("image"), 0u);
  EXPECT_NEAR(summary.path_length_m, 22.3, 0.1);
  EXPECT_GT(summary.output_bytes, 1000u);
  EXPECT_TRUE(summary.faults.empty());

  const Dataset d = readAll(out);
  EXPECT_TRUE(d.issues.empty());
  ASSERT_EQ(d.manifest.cameras.size(), 7u);
  ASSERT_EQ(d.manifest.cameras[0].role, SensorRole::kFisheye);
  ASSERT_TRUE(d.manifest.cameras[0].camera);
  const Camera& fisheye = *d.manifest.cameras[0].camera;
  EXPECT_EQ(fisheye.width(), 640);
  const GroundTruth& truth = d.manifest.ground_truth;
  ASSERT_EQ(truth.world_from_camera.size(), 6u);
  ASSERT_TRUE(truth.fisheye_from_marker);
  EXPECT_GT(truth.fisheye_from_marker->translation.norm(), 0.1);  // a real mount, not identity
  ASSERT_TRUE(d.manifest.findTrajectory("odometry"));
  ASSERT_TRUE(d.manifest.findTrajectory("ground_truth"));
  // Clocks: every node 1-2 ms off true time, so offsets to the robot's clock within +-4 ms, not all
  // 0.
  int nonzero = 0;
  for (const auto& [label, offset] : truth.clock_offset) {
    EXPECT_LE(std::abs(offset), millisecondsToNs(4)) << label;
    nonzero += offset != 0;
  }
  EXPECT_GE(nonzero, 5);

  const Trajectory gt = d.trajectory("ground_truth");
  const Trajectory odometry = d.trajectory("odometry");
  ASSERT_GT(gt.size(), 300u);
  ASSERT_GT(odometry.size(), gt.size());

  // Markers: truth + noise of the stated information (0.2 mm allowed for
  // the interpolation of the 10 Hz ground truth). Mapping the camera's stamp
  // to the robot's clock matters: the 1-4 ms offsets move the robot by mm.
  double chi2_rotation = 0, chi2_translation = 0;
  int n = 0;
  std::set<std::string> cameras_seen;
  for (const MarkerObservation& obs : d.all<MarkerObservation>()) {
    const auto truth_pose = trueCameraFromMarker(d, gt, obs);
    ASSERT_TRUE(truth_pose) << obs.t;
    EXPECT_EQ(obs.marker_id, 7);
    const Vector6d e = markerError(obs, *truth_pose);
    EXPECT_LT(e.head<3>().norm(), 0.15);
    EXPECT_LT(e.tail<3>().norm(), 2.5);  // tilt of an 18 px marker: sigma up to 0.5 rad
    ASSERT_GT(obs.information.determinant(), 0);
    Matrix6d covariance = obs.information.inverse();
    covariance.topLeftCorner<3, 3>() += 0.0002 * 0.0002 * Eigen::Matrix3d::Identity();
    EXPECT_LT(e.dot(covariance.inverse() * e), 40) << obs.t;  // chi2(6) > 40: p < 1e-6
    chi2_translation += e.head<3>().dot(covariance.topLeftCorner<3, 3>().inverse() * e.head<3>());
    chi2_rotation += e.tail<3>().dot(obs.information.bottomRightCorner<3, 3>() * e.tail<3>());
    ++n;
    cameras_seen.insert(obs.camera);
    // In-plane rotation (about the marker's normal) is far better known than tilt.
    EXPECT_GT(obs.information(5, 5), obs.information(3, 3));
  }
  ASSERT_GT(n, 50);
  EXPECT_EQ(cameras_seen.size(), 6u);
  EXPECT_NEAR(chi2_rotation / n, 3.0, 0.75);  // E[chi2(3)] = 3
  EXPECT_NEAR(chi2_translation / n, 3.0, 0.75);

  // Blobs: the housings' centres projected into the fisheye, plus noise.
  const double blob_sigma = loadScenario("small").noise.blob_sigma_px;
  const double margin = loadScenario("small").noise.image_margin_px;
  double residual2 = 0;
  int blobs = 0, expected = 0, hidden = 0;
  for (const BlobObservation& obs : d.all<BlobObservation>()) {
    EXPECT_EQ(obs.camera, "fisheye");
    EXPECT_EQ(obs.image_width, 640);
    EXPECT_EQ(obs.image_height, 360);
    const InterpolationResult at = gt.interpolate(obs.t, 0);
    ASSERT_TRUE(at.ok());
    ASSERT_EQ(at.t_before, obs.t);  // the ground truth is sampled at the fisheye's frames
    std::vector<Eigen::Vector2d> projections;
    for (const auto& [label, world_from_camera] : truth.world_from_camera) {
      const auto pixel =
          fisheye.project(at.world_from_body.inverse() * world_from_camera.translation);
      if (!pixel || !fisheye.isInImage(*pixel, margin)) continue;
      // The manifest's hidden spans are the housings the simulated detector
      // cannot see: every other one in the image has its blob.
      if (truth.hiddenFromFisheye(label, obs.t)) {
        ++hidden;
        continue;
      }
      projections.push_back(*pixel);
    }
    expected += static_cast<int>(projections.size());
    EXPECT_EQ(obs.blobs.size(), projections.size()) << obs.t;
    for (const Blob& blob : obs.blobs) {
      double nearest = 1e9;
      for (const Eigen::Vector2d& p : projections)
        nearest = std::min(nearest, (p - Eigen::Vector2d(blob.u, blob.v)).norm());
      EXPECT_LT(nearest, 6 * blob_sigma) << obs.t;
      EXPECT_GT(blob.diameter_px, 1.0);
      residual2 += nearest * nearest;
      ++blobs;
    }
  }
  EXPECT_GT(blobs, 1000);
  // The stated noise: E[d^2] = 2 sigma^2 for an isotropic 2-D Gaussian.
  EXPECT_NEAR(std::sqrt(residual2 / (2 * blobs)), blob_sigma, 0.1 * blob_sigma);
  EXPECT_EQ(blobs, expected);
  EXPECT_GT(hidden, 0.05 * expected);  // behind beams and ducts

  // Odometry: metric, starts on the truth, drifts a little.
  const Rigid3d first = odometry.samples().front().world_from_body;
  const InterpolationResult gt_first = gt.interpolate(odometry.startTime(), 0);
  if (gt_first.ok()) {
    EXPECT_LT((first.translation - gt_first.world_from_body.translation).norm(), 0.05);
  }
  const Rigid3d last = odometry.samples().back().world_from_body;
  const double drift = (last.translation - gt.samples().back().world_from_body.translation).norm();
  EXPECT_LT(drift, 0.05 * summary.path_length_m);
}

TEST_F(SimulateTest, SameSeedSameOutputOtherSeedOtherOutput) {
  run("small", dir_ / "a" / "x.rawlog", true, std::nullopt, 12);
  run("small", dir_ / "b" / "x.rawlog", true, std::nullopt, 12);
  run("small", dir_ / "c" / "x.rawlog", true, 12345u, 12);
  const std::string a = dump(readAll(dir_ / "a" / "x.rawlog"));
  const std::string b = dump(readAll(dir_ / "b" / "x.rawlog"));
  const std::string c = dump(readAll(dir_ / "c" / "x.rawlog"));
  EXPECT_GT(a.size(), 10000u);
  EXPECT_EQ(a, b);
  EXPECT_NE(a, c);
  // The folder format holds the same records.
  run("small", dir_ / "f" / "x", true, std::nullopt, 12, DatasetKind::kFolder);
  const Dataset folder = readAll(dir_ / "f" / "x");
  const Dataset rawlog = readAll(dir_ / "a" / "x.rawlog");
  EXPECT_EQ(folder.all<MarkerObservation>().size(), rawlog.all<MarkerObservation>().size());
  EXPECT_EQ(folder.all<BlobObservation>().size(), rawlog.all<BlobObservation>().size());
}

// noise.marker_corners: every marker carries corners that its pose explains,
// the pose's error matches its information, and everything else (blobs,
// trajectories, which frames hold a marker) is what the default gives.
TEST_F(SimulateTest, MarkerCornersOptionAddsCornersAndLeavesTheRestAlone) {
  std::ifstream in(builtinScenarioDirectory() / "small.yaml");
  std::string yaml((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string from = "blob_sigma_px: 1.2}";
  const size_t at = yaml.find(from);
  ASSERT_NE(at, std::string::npos) << "small.yaml changed: update this test";
  yaml.replace(at, from.size(), "blob_sigma_px: 1.2, marker_corners: true}");
  const fs::path scenario = dir_ / "small_corners.yaml";
  std::ofstream(scenario) << yaml;
  ASSERT_TRUE(loadScenario(scenario.string()).noise.marker_corners);
  EXPECT_FALSE(loadScenario("small").noise.marker_corners);
  run(scenario.string(), dir_ / "c" / "x.rawlog", true, std::nullopt, 12);
  run("small", dir_ / "d" / "x.rawlog", true, std::nullopt, 12);
  const Dataset with = readAll(dir_ / "c" / "x.rawlog");
  const Dataset without = readAll(dir_ / "d" / "x.rawlog");
  EXPECT_TRUE(with.issues.empty());

  auto others = [](const Dataset& d) {
    Dataset rest = d;
    rest.manifest.rawlog_entries = -1;  // corner entries count in it
    rest.records.clear();
    for (const Record& r : d.records)
      if (!std::holds_alternative<MarkerObservation>(r)) rest.records.push_back(r);
    return dump(rest);
  };
  EXPECT_EQ(others(with), others(without));
  const auto markers = with.all<MarkerObservation>();
  const auto plain = without.all<MarkerObservation>();
  ASSERT_EQ(markers.size(), plain.size());
  ASSERT_GT(markers.size(), 40u);

  const double sigma = loadScenario("small").noise.marker_corner_sigma_px;
  const Camera& camera = *with.manifest.findCamera(markers[0].camera)->camera;
  const Trajectory gt = with.trajectory("ground_truth");
  const double h = 0.5 * with.manifest.marker.size_m;
  const Eigen::Vector3d corners_in_marker[4] = {{-h, h, 0}, {h, h, 0}, {h, -h, 0}, {-h, -h, 0}};
  double nees = 0;
  for (size_t i = 0; i < markers.size(); ++i) {
    const MarkerObservation& m = markers[i];
    EXPECT_EQ(m.camera, plain[i].camera);
    EXPECT_EQ(m.t, plain[i].t);
    EXPECT_TRUE(plain[i].corners_px.empty());
    ASSERT_EQ(m.corners_px.size(), 4u);
    EXPECT_EQ(m.corner_sigma_px, sigma);
    // The pose is the least-squares fit of its corners: residuals below the noise.
    double squared = 0;
    for (int k = 0; k < 4; ++k) {
      const auto pixel = camera.project(m.camera_from_marker * corners_in_marker[k]);
      ASSERT_TRUE(pixel);
      squared += (*pixel - m.corners_px[static_cast<size_t>(k)]).squaredNorm();
    }
    EXPECT_LT(std::sqrt(squared / 8), 3 * sigma) << m.t;
    const auto truth = trueCameraFromMarker(with, gt, m);
    ASSERT_TRUE(truth);
    const Vector6d e = markerError(m, *truth);
    Matrix6d covariance = m.information.inverse();
    covariance.topLeftCorner<3, 3>() += 0.0002 * 0.0002 * Eigen::Matrix3d::Identity();
    nees += e.dot(covariance.inverse() * e);
  }
  const double mean_nees = nees / static_cast<double>(markers.size()) / 6.0;
  std::printf("marker_corners: %zu markers, mean NEES / 6 = %.3f\n", markers.size(), mean_nees);
  EXPECT_GT(mean_nees, 0.6);
  EXPECT_LT(mean_nees, 1.5);
}

TEST_F(SimulateTest, FaultsShowUp) {
  const fs::path out = dir_ / "faults.rawlog";
  const SimulateSummary summary = run("faults", out, true);
  EXPECT_EQ(summary.cameras, 7);
  auto has = [&](const std::string& text) {
    for (const std::string& f : summary.faults)
      if (f.find(text) != std::string::npos) return true;
    return false;
  };
  EXPECT_TRUE(has("duplicated timestamps"));
  EXPECT_TRUE(has("dropped frames"));
  EXPECT_TRUE(has("never passed under"));
  EXPECT_TRUE(has("250.0 ms more"));
  EXPECT_TRUE(has("false marker detections"));
  EXPECT_TRUE(has("occluded marker detections"));
  EXPECT_TRUE(has("motion-blurred fisheye frames"));
  EXPECT_TRUE(has("plain ceiling"));

  const Dataset d = readAll(out);
  // Duplicated stamps: the reader reports (and drops) them.
  int duplicates = 0;
  for (const DatasetIssue& issue : d.issues)
    duplicates += issue.message.find("repeats timestamp") != std::string::npos;
  EXPECT_EQ(duplicates, 6);
  // A camera with no detection at all.
  std::map<std::string, int> markers;
  for (const MarkerObservation& m : d.all<MarkerObservation>()) ++markers[m.camera];
  EXPECT_EQ(markers.size(), 6u);
  EXPECT_EQ(markers.count("cam06"), 0u);
  EXPECT_EQ(d.manifest.ground_truth.world_from_camera.size(), 7u);
  // One clock 250 ms off.
  int jumped = 0;
  for (const auto& [label, offset] : d.manifest.ground_truth.clock_offset)
    jumped += std::abs(offset) > millisecondsToNs(200);
  EXPECT_EQ(jumped, 1);
  // False detections: markers far from where the robot's marker is.
  const Trajectory gt = d.trajectory("ground_truth");
  int false_markers = 0;
  for (const MarkerObservation& m : d.all<MarkerObservation>()) {
    const auto truth = trueCameraFromMarker(d, gt, m);
    if (!truth || (truth->translation - m.camera_from_marker.translation).norm() > 0.3)
      ++false_markers;
  }
  EXPECT_GE(false_markers, 1);
  // Dropped fisheye frames: fewer blob records than ground-truth samples.
  EXPECT_LT(d.all<BlobObservation>().size() + 5, gt.size());
}

TEST_F(SimulateTest, RendersFramesWhoseNoiseMatchesTheDetectionsModel) {
  const fs::path out = dir_ / "render";
  const SimulateSummary summary = run("small", out, false, std::nullopt, 14, DatasetKind::kFolder);
  EXPECT_GT(summary.records.at("image"), 200);
  const Dataset d = readAll(out);
  std::map<std::string, int> frames;
  std::set<TimeNs> fisheye_stamps;
  for (const ImageFrame& frame : d.all<ImageFrame>()) {
    ++frames[frame.sensor];
    if (frame.sensor == "fisheye") fisheye_stamps.insert(frame.t);
    // Decode a few: non-trivial greyscale frames of the calibrated size.
    if (frames[frame.sensor] % 20 != 1) continue;
    const cv::Mat image = cv::imread(frame.image_file.string(), cv::IMREAD_UNCHANGED);
    ASSERT_FALSE(image.empty()) << frame.image_file;
    EXPECT_EQ(image.type(), CV_8UC1);
    EXPECT_EQ(image.cols, 640);
    EXPECT_EQ(image.rows, 360);
    cv::Scalar mean, stddev;
    cv::meanStdDev(image, mean, stddev);
    EXPECT_GT(stddev[0], 10) << frame.image_file;
    EXPECT_GT(mean[0], 20) << frame.image_file;
  }
  EXPECT_GE(frames["fisheye"], 130);
  EXPECT_GE(frames.size(), 3u);  // the robot passed under cameras
  // The ground truth is sampled at the fisheye's frames.
  for (const PoseSample& p : d.all<PoseSample>()) {
    if (p.label == "ground_truth") {
      EXPECT_TRUE(fisheye_stamps.count(p.t)) << p.t;
    }
  }
  // The detections-only noise of the 640x360 scenarios is what plain OpenCV
  // finds in these frames (doc/formats.md, "Where the numbers come from").
  const Scenario small = loadScenario("small");
  const auto [corner_rms, markers] = measuredCornerNoise(d, 2);
  EXPECT_GT(markers, 100);
  EXPECT_GT(corner_rms, 0.6 * small.noise.marker_corner_sigma_px);
  EXPECT_LT(corner_rms, 1.6 * small.noise.marker_corner_sigma_px);
  const auto [blob_rms, blobs] = measuredBlobNoise(d, 2);
  EXPECT_GT(blobs, 300);
  EXPECT_GT(blob_rms, 0.6 * small.noise.blob_sigma_px);
  EXPECT_LT(blob_rms, 1.6 * small.noise.blob_sigma_px);
}

TEST_F(SimulateTest, PaperFramesMatchTheNoiseModel) {
  // The robot stands under a camera for the first second: 9 frames of each.
  const fs::path out = dir_ / "paper.rawlog";
  run("paper", out, false, std::nullopt, 0.3);
  const Dataset d = readAll(out);
  const Scenario paper = loadScenario("paper");
  const auto [corner_rms, markers] = measuredCornerNoise(d, 5);
  EXPECT_GE(markers, 8);
  EXPECT_GT(corner_rms, 0.5 * paper.noise.marker_corner_sigma_px);
  EXPECT_LT(corner_rms, 1.6 * paper.noise.marker_corner_sigma_px);
  const auto [blob_rms, blobs] = measuredBlobNoise(d, 10);
  EXPECT_GT(blobs, 50);
  EXPECT_GT(blob_rms, 0.6 * paper.noise.blob_sigma_px);
  EXPECT_LT(blob_rms, 1.6 * paper.noise.blob_sigma_px);
}

TEST_F(SimulateTest, StopsCleanly) {
  SimulateOptions options;
  options.scenario = "small";
  options.out = dir_ / "stopped.rawlog";
  const ProgressReporter progress;
  progress.requestStop();
  EXPECT_THROW(simulate(options, progress), StopRequested);
  EXPECT_FALSE(fs::exists(options.out));
  EXPECT_FALSE(fs::exists(dir_ / "stopped.yaml"));
}

TEST_F(SimulateTest, RejectsBadOptions) {
  SimulateOptions options;
  options.out = dir_ / "x.bag";
  EXPECT_NE(options.check().find("'--out'"), std::string::npos);
  EXPECT_THROW(simulate(options, ProgressReporter()), Error);
  options.out = dir_ / "x.rawlog";
  options.scenario = "nope";
  try {
    simulate(options, ProgressReporter());
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("faults, paper, revisit, small"), std::string::npos);
  }
  // An existing output is not replaced without overwrite.
  options.scenario = "small";
  options.detections_only = true;
  options.max_duration_s = 2;
  simulate(options, ProgressReporter());
  EXPECT_THROW(simulate(options, ProgressReporter()), Error);
  options.overwrite = true;
  EXPECT_NO_THROW(simulate(options, ProgressReporter()));
}

}  // namespace
}  // namespace lookboth::sim
