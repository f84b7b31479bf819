// Private: stage `joint` (beyond the paper) as a class whose steps are its
// methods, so that each can be read, changed and tested alone. One Ceres
// problem over
//   - trajectory nodes N_k = world_from_fisheye (metric) at input samples at
//     least node_interval_s apart, tied by the input's relative motions
//     weighted by a drift model (sigma^2 = min^2 + drift^2 * distance) and a
//     scale per segment of scale_segment_m metres (random-walk prior between
//     segments; metric mode: also a prior around 1);
//   - fisheye_from_marker X (components motion_calibration found undetermined
//     get a prior at its value);
//   - every camera's world_from_camera C;
//   - every camera's clock offset o (node clock - robot clock) [s], weak prior;
// with the measurements
//   - marker detections: the 4 corners reprojected through the camera's model
//     (when present), else the 6-DoF pose error whitened by the detection's
//     information; Huber; chi-square rejection between rounds;
//   - blobs in the fisheye: the camera centre (+ blob_offset_in_camera_m)
//     reprojected; Cauchy; look_up's gated, unambiguous nearest-neighbour
//     association re-run at the current estimate each round.
// A time t between nodes k and k+1 has the pose
//   P(t) = Interp(N_k Nref_k^-1, N_k+1 Nref_k+1^-1, alpha) * Fref(t),
// Nref/Fref the initial (input, scaled) trajectory, alpha = (t - t_k) / (t_k+1 - t_k),
// Interp linear in translation and slerp in rotation: the input's shape between
// nodes is kept and only its correction is interpolated. For detections
// t = t_camera - o; Fref(t) is expanded to first order around the previous
// round's t (body velocity), so the offset is differentiable.
//
// Gauge: the first node is held at the input's first pose (scaled): the
// registration's world is the trajectory's first pose, as for the paper's
// stages (doc/conventions.md). With camera priors (a registration on record,
// RegistrationProblem::camera_priors) the priors fix it instead: the world is
// the record's, and nothing is held.
//
// A joint run again on the same problem (`register --update`) starts where
// the earlier one ended: its corrected trajectory and clock offsets, and the
// drift model it estimated from the same data, kept as it is.
//
// The steps, in the order run() takes them (and the file that holds each):
//   setup (joint_setup.cpp): the inputs checked, the reference trajectory
//     (smoothed when it jitters), the nodes and scale segments, the cameras
//     (the unregistered given a clock search, joint_clock_search.cpp), their
//     detections and the fisheye's blob frames;
//   rounds (joint_rounds.cpp): each round re-brackets the detections at the
//     current clock offsets, rejects outliers, re-associates the blobs,
//     builds the Ceres problem and solves it; between rounds the drift model
//     may be re-estimated (joint_drift_model.cpp);
//   results (joint_results.cpp): the covariance, then fisheye_from_marker,
//     the scale, the corrected trajectory, the cameras and Table I's
//     reprojection statistics written into the problem's Registration.
#pragma once
#include <ceres/ceres.h>

#include <array>
#include <cmath>
#include <ctime>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "joint_bracket.h"
#include "lookboth/calib/joint.h"
#include "lookboth/cameras/camera.h"
#include "lookboth/solver/fill_reducing_ordering.h"
#include "lookboth/solver/sparse_covariance.h"

namespace lookboth::joint_detail {

// Process CPU time [s], for the verbose breakdown.
inline double processCpuSeconds() { return static_cast<double>(std::clock()) / CLOCKS_PER_SEC; }

constexpr double kDeg = M_PI / 180.0;
constexpr TimeNs kMaxGapNs = 500'000'000;     // trajectory gaps longer than this are not crossed
constexpr double kDriftModelTolerance = 0.1;  // a drift sigma factor changed by more: another round
constexpr TimeNs kSmoothingGapNs = 100'000'000;  // samples farther apart: not smoothed across
constexpr double kRebracketS = 0.005;  // clock offsets moved less: no new round (inputsChanged)
// A clock offset estimated this far [ms] from the configured one, and
// beyond 3 sigma, is reported: a sixth of a 30 Hz frame period.
constexpr double kMinClockChangeMs = 5.0;
// A fisheye_from_marker component neither determined nor held by a prior is
// a warning when its sigma exceeds this many times max_*_sigma (1 cm and
// 2.5 deg by default); below, a note.
constexpr double kLooseFactor = 5.0;

/// A marker detection as the adjustment holds it.
struct Detection {
  std::size_t association = 0;
  std::size_t camera = 0;  // index into the adjustment's cameras
  bool corners = false;    // reprojected corners (else the 6-DoF pose error)
  bool inlier = true;
  bool in_range = true;  // its time (at the current clock offset) is between nodes
  Matrix6d sqrt_info = Matrix6d::Identity();
  TimeNs t_camera = 0;
};

/// An environment camera's parameter blocks and what it is measured by.
struct JointCamera {
  /// Offsets this far from the configured one are no synchronisation's
  /// (the clock search moves by whole 10 ms steps) [s].
  static constexpr double kUnsynchronisedFrom_s = 0.005;
  void judgeClock() { unsynchronised = std::abs(offset_s - offset0_s) >= kUnsynchronisedFrom_s; }

  CameraRegistration* registration = nullptr;
  const Camera* model = nullptr;  // env camera calibration (corners), may be null
  double pose[7];
  Rigid3d start;         // the pose the joint started from (look_up's, or the restart's)
  double offset_s = 0;   // node - robot [s]
  double offset0_s = 0;  // configured (associate) [s]
  /// The clock search (or an earlier run) put its offset 5 ms or more from
  /// the configured one: its clock is not synchronised, and its prior is
  /// unsynchronised_clock_prior_sigma_s.
  bool unsynchronised = false;
  std::vector<std::size_t> detections;
  int blobs = 0;
  /// Held near a registration on record (RegistrationProblem::camera_priors).
  std::optional<Rigid3d> prior;
  Matrix6d prior_sqrt_info = Matrix6d::Zero();
};

/// A fisheye frame with blobs, and where its time falls between the nodes.
struct BlobFrame {
  const BlobObservation* blobs;
  Bracket bracket;
};

/// A relative-motion cost between two consecutive nodes at samples of the
/// input (the nodes added between samples aside): its motion between them
/// (the drift model).
struct TrajectoryEdge {
  std::size_t from = 0, to = 0;  // node indices, from < to
  bool gap = false;              // an interval of the input between them is a gap
  std::size_t segment = 0;       // the scale segment
  double length_m = 0;           // the reference's distance between the nodes [m]
};

/// A trajectory residual block the drift model is estimated from, with its
/// parameter blocks and whether it is a SmoothMotionCost (else a RelativeMotionCost).
struct DriftResidual {
  ceres::ResidualBlockId id;
  std::array<double*, 3> blocks;
  bool smooth;
};

/// Blob `blob` of frame `frame`, associated with a camera.
struct BlobMatch {
  std::size_t frame, blob;
};

/// The drift model estimated from the data (estimate_drift_model): factors on
/// the configured sigmas of the relative motions' horizontal translation,
/// vertical translation, tilt (roll, pitch) and yaw, and of the smooth
/// motion between samples' velocity and angular rate (between_samples_*).
struct DriftModelState {
  static constexpr int kGroups = 6;
  double factor[kGroups] = {1, 1, 1, 1, 1, 1};
  double last_step[kGroups] = {1, 1, 1, 1, 1, 1};  // each group's last update step
  bool changed = false;                            // by the update after this round: another round
  bool still_changing = false;  // the last update made changed the model (> 10 %)
  int updates = 0;              // made (each followed by a round)
  bool failed = false;          // its covariance could not be computed
};

// The clock searches' pieces (joint_clock_search.cpp).

// Component-wise median of the poses' positions (not empty).
Eigen::Vector3d medianPosition(const std::vector<Rigid3d>& poses);
// Per-detection camera poses made to share their mean rotation, each keeping
// where it puts the marker (`marker_in_camera[i]` goes with candidate i).
void shareMeanRotation(std::vector<Rigid3d>& candidates,
                       const std::vector<Eigen::Vector3d>& marker_in_camera);
// The median distance of the poses' positions from `centre` (infinity: none).
double medianDistance(const std::vector<Rigid3d>& poses, const Eigen::Vector3d& centre);
// Of trial clock shifts [s] with their detections' spreads [m] and blob
// scores [px] (NaN: none), the index of the one a restart takes;
// `admissible_m` (optional): the largest spread it considered.
std::size_t chooseShift(const std::vector<double>& shifts, const std::vector<double>& spreads,
                        const std::vector<double>& blob_scores, double* admissible_m = nullptr);

class FramePoseCache;  // joint_costs.h

class JointAdjustment {
 public:
  JointAdjustment(RegistrationProblem& problem, const JointOptions& options,
                  const ProgressReporter& progress);
  /// Runs every step; the results go to the problem and its Registration.
  void run();

 private:
  // ---- setup (joint_setup.cpp) ----
  void checkInputs() const;
  void prepareReferenceTrajectory();
  void initFisheyeFromMarker();
  void buildNodes();
  void pushNode(TimeNs t, const Rigid3d& input_pose, bool between_samples, bool gap_before);
  void buildEdges();
  void initCameras();
  void collectDetections();
  void collectBlobFrames();
  void configureSolver();
  // An earlier joint's estimates on this problem as the start (warm start).
  void startFromEarlierRun();
  // The reference (input, scaled) world_from_fisheye at t; none in a gap.
  std::optional<Rigid3d> referenceAt(TimeNs t) const;
  // The bracket of time t (robot clock); none outside the nodes or in a gap.
  std::optional<Bracket> bracketAt(TimeNs t, bool with_velocity) const;
  // world_from_fisheye at the current nodes, `tau_s` after the bracket's first.
  Rigid3d evalPose(const Bracket& b, double tau_s) const;

  // ---- clock searches (joint_clock_search.cpp) ----
  // An unregistered camera's start (pose and clock shift [s] from the
  // configured offset) from its detections; none when they cannot give one.
  std::optional<std::pair<Rigid3d, double>> restartCamera(const CameraRegistration& camera) const;
  // Whether the camera's clock prior is the unsynchronised one.
  bool unsynchronised(const JointCamera& c) const;
  // The restarted cameras' clock search again, on the corrected trajectory.
  void researchRestartedClocks();

  // ---- rounds (joint_rounds.cpp) ----
  void solveRounds();
  // Whether a round past `rounds` is needed (a drift model that changed).
  bool roundNeeded(int round) const;
  bool driftUpdateFollows(int round) const;
  void bracketDetections();
  void rejectOutliers(int round);
  void associateBlobs();
  // Records this round's inputs; false when they are those of the last
  // round, which converged: no new round.
  bool inputsChanged(int round);
  ceres::CostFunction* markerCost(std::size_t i) const;
  double markerChi2(std::size_t i) const;
  void buildProblem(bool drift_update_follows);
  void addNode(std::size_t k);
  void addTrajectory();
  void addFisheyeFromMarker();
  void addCamerasAndDetections();
  void addBlobs(bool drift_update_follows);
  void chooseOrdering();
  // The blob frames' poses and their derivatives at the current estimate
  // (before the problem is evaluated outside Solve).
  void prepareFramePoses();
  void solveRound(int round, bool drift_update_follows);
  // Verbose: the parameters before a round, how far the round moved each
  // kind (the largest move), and the round's solver summary and costs.
  struct Snapshot {
    std::vector<std::array<double, 7>> nodes;
    std::vector<std::array<double, 7>> cameras;
    std::vector<double> offsets, scales;
    std::array<double, 7> x{};
  };
  Snapshot snapshot() const;
  void reportMoves(int round, const Snapshot& before) const;
  void reportRound(int round, const ceres::Solver::Summary& summary, double cpu_setup);

  // ---- drift model (joint_drift_model.cpp) ----
  // Helmert's variance component estimation after a round; true when the
  // model changed by more than kDriftModelTolerance.
  bool updateDriftModel();
  bool leverageOf(const DriftResidual& d, const SparseCovariance& cov, double* r,
                  Eigen::Matrix<double, 6, 6>& leverage) const;

  // ---- results (joint_results.cpp) ----
  void noteModelEstimates();
  void countDetections();
  void computeCovariance();
  void computePassCovariance();
  Matrix6d informationOn(ceres::ResidualBlockId id, double* block) const;
  // A camera's passes, each the residual blocks of one: its marker
  // detections' (0) and its blobs' (1), split where a gap exceeds pass_gap_s.
  using PassGroups = std::vector<std::vector<ceres::ResidualBlockId>>;
  std::vector<std::array<PassGroups, 2>> passesByCamera() const;
  // What the shared errors add to cameras a and b's poses' covariance: the
  // whole problem's sandwich (computeSharedErrorSpread) when it was computed,
  // else each camera's given the trajectory (computePassCovariance, a == b).
  Matrix6d passCovariance(std::size_t a, std::size_t b) const;
  bool computeSharedErrorSpread();
  Eigen::MatrixXd passTimesColumns(const std::vector<ceres::ResidualBlockId>& pass,
                                   const double* pose, const Eigen::MatrixXd& Y, Matrix6d* h) const;
  void computeAlignedPrediction();
  void writeFisheyeFromMarker();
  void writeScale();
  void writeTrajectory();
  void writeCamera(std::size_t c);
  void writeReprojection();

  // Process CPU time since the last lap [s], for the verbose breakdown.
  double lap();

  RegistrationProblem& problem_;
  const JointOptions& options_;
  const ProgressReporter& progress_;
  const RegistrationInput& input_;
  Registration& result_;
  bool verbose_ = false;              // LOOKBOTH_JOINT_VERBOSE: diagnostics on stderr
  bool verbose_every_round_ = false;  // =2: Ceres' full report of every round
  bool visual_ = false;
  double scale0_ = 1;               // motion_calibration's scale
  bool held_by_priors_ = false;     // camera priors fix the gauge (no node held)
  bool drift_model_given_ = false;  // an earlier run's estimate, kept (startFromEarlierRun)

  // The reference trajectory (the input, or its smoothed positions).
  std::optional<Trajectory> reference_;
  const std::vector<StampedPose>* samples_ = nullptr;

  // fisheye_from_marker: the start, and its parameter block.
  Rigid3d X0_;
  double x_params_[7];
  std::array<bool, 6> prior_on_ = {false, false, false, false, false, false};

  // Trajectory nodes and scale segments.
  TimeNs max_gap_ns_ = kMaxGapNs;  // effectiveMaxGap of the reference
  std::vector<TimeNs> node_t_;
  std::vector<Rigid3d> node_input_;         // the input (reference) at each node, its own units
  std::vector<Rigid3d> node_ref_;           // Nref (scaled input)
  std::vector<bool> node_between_samples_;  // added between two samples
  std::vector<bool> node_gap_before_;       // a gap of the input since the node before
  std::vector<std::array<double, 7>> nodes_;
  std::vector<TrajectoryEdge> edges_;
  std::vector<std::size_t> smooth_middles_;  // SmoothMotionCost's middle nodes
  std::size_t n_segments_ = 1;
  std::vector<double> scales_;

  // Cameras and measurements.
  const Camera* blob_fisheye_ = nullptr;  // the fisheye for the clock searches
  std::vector<JointCamera> cameras_;
  // Unregistered by look_down, given another chance here: label -> offset
  // found by the clock search, relative to the configured one [s].
  std::map<std::string, double> restarted_;
  std::array<Eigen::Vector3d, 4> corners_in_marker_;
  std::vector<Detection> detections_;
  std::vector<std::optional<Bracket>> det_bracket_;  // at the current offsets
  const Camera* fisheye_ = nullptr;
  bool use_blobs_ = false;
  std::vector<BlobFrame> frames_;
  std::vector<std::vector<BlobMatch>> matches_;  // per camera

  // Rounds.
  int max_rounds_ = 0;
  // Variance factor of the marker measurements (pose, corners): how much
  // larger their residuals are, in variance, than the detector's covariance
  // says (the trajectory between nodes, a detector that underrates its
  // noise). Estimated from the median chi-square between rounds, never
  // below 1; the costs and the rejection are scaled by it.
  double variance_factor_[2] = {1.0, 1.0};
  ceres::Solver::Options solver_;
  FillOrderingMethod fill_method_ = FillOrderingMethod::kAuto;
  struct {
    bool made = false;
    double residuals = 0;  // residual blocks of the round it was made on
    FillOrderingMethod method = FillOrderingMethod::kAmd;
  } ordering_choice_;          // auto's last choice
  std::string ordering_note_;  // verbose: the round's ordering
  // The losses and the frame-pose cache are shared by many blocks: the
  // problem does not own them, and is destroyed before them.
  std::unique_ptr<ceres::LossFunction> huber_, cauchy_;
  // The blob frames' poses at each evaluation point (shared: its type is
  // complete only where the costs are built, joint_rounds.cpp).
  std::shared_ptr<FramePoseCache> frame_poses_;
  std::unique_ptr<ceres::Problem> ceres_problem_;
  std::vector<bool> node_used_;  // in this round's problem
  // The trajectory's residual blocks the drift model is estimated from: the
  // edges' (not across a gap) and the smooth motion's.
  std::vector<DriftResidual> drift_residuals_;
  // Verbose diagnostics: the cost of the odometry, marker and blob residuals apart.
  std::array<std::vector<ceres::ResidualBlockId>, 3> group_blocks_;
  // The marker detections' residual blocks, with the detection's index, and
  // the blobs', with their camera and frame time (computePassCovariance).
  std::vector<std::pair<ceres::ResidualBlockId, std::size_t>> marker_blocks_;
  struct BlobBlock {
    ceres::ResidualBlockId id;
    std::size_t camera;
    TimeNs t;
  };
  std::vector<BlobBlock> blob_blocks_;
  double cpu_mark_ = 0;
  std::vector<char> previous_inlier_;
  std::vector<double> previous_offset_;
  std::size_t previous_blobs_ = 0;
  bool previous_converged_ = true;  // the last round's solve converged (not stopped at its cap)
  // The inliers of the last round were judged on a converged estimate (a
  // short drift round's is not: the round after it judges them again).
  bool inliers_judged_converged_ = true;
  // The last round was a short drift round (drift_round_max_*, after the
  // first update): its estimate is a step on the way, where good detections
  // can sit several sigmas off, and a detection set aside there stays out (a
  // flexible trajectory follows the detections kept). The round after it
  // keeps the inliers and variance factors as they were; outliers are judged
  // on converged estimates only: after the first round (which runs to
  // convergence) and after the round that follows the last update.
  bool previous_short_ = false;
  // The clock search of the restarted cameras again after the first round,
  // on the trajectory that round corrected: there a camera put at the right
  // offset projects within a pixel or two of its blob, where on the input
  // trajectory the score was tens of pixels and flat (one pass in one
  // direction trades a clock shift for a tilt of the camera). The offset
  // moves only when another is clearly better (1 px or 20 % of the score).
  // Cameras the search just moved: their pose is a rough start (the median of
  // their detections), so the next rejection keeps all of their detections
  // and leaves them out of the variance factors; the round after judges them.
  std::vector<bool> restarted_now_;
  DriftModelState drift_;

  // Results.
  std::vector<int> used_, rejected_;  // detections per camera
  SparseCovariance covariance_;
  bool have_covariance_ = false;
  bool scale_covariance_ = false;  // the scales' covariance is computed
  // The cameras' positions after a rigid alignment (aligned_position_rmse_m).
  std::vector<std::size_t> aligned_cameras_;
  bool aligned_prediction_ = false;
  std::map<std::size_t, Eigen::Matrix3d> aligned_position_covariance_;  // by camera index
  // What the pass-shared detection errors add to each camera's pose
  // covariance (pass_error_share), in its parameters' tangent; by camera index.
  std::map<std::size_t, Matrix6d> pass_covariance_;
  // The sandwich over the whole problem: 6x6 blocks by camera column.
  Eigen::MatrixXd spread_;
  std::map<std::size_t, std::size_t> spread_column_;  // camera index -> block column
};

}  // namespace lookboth::joint_detail
