// The stage "joint", beyond the paper: one adjustment of the trajectory, its
// scale, fisheye_from_marker, the cameras and their clock offsets, from the
// marker detections and the blobs, with the odometry's drift model estimated
// from the data (src/joint_adjustment.h).
#pragma once
#include <Eigen/Geometry>
#include <map>
#include <optional>
#include <string>

#include "lookboth/calib/problem.h"
#include "lookboth/calib/stage_registry.h"

namespace lookboth {

struct JointOptions {
  // --- trajectory ---
  /// Trajectory nodes: the input's samples at least this far apart in time,
  /// and nodes every this often between samples more than twice that apart
  /// (between_samples_*) [s] (0 = every sample, none added); detections and
  /// fisheye frames between two nodes are interpolated between them inside
  /// the cost.
  double node_interval_s = 0.1;
  /// Visual mode: the input trajectory's positions are replaced by a local
  /// quadratic fit in time over +-this many seconds (0 = as given) before they
  /// serve as the shape between nodes: a visual odometry's frame-to-frame
  /// position jitter would otherwise reach every detection's pose [s].
  double smooth_input_s = 0.2;
  /// ...when the positions scatter about those fits by more than this RMS
  /// (trajectory units of a visual odometry: metres after the initial scale)
  /// [m]; a smoother input is used as given.
  double smooth_input_min_rms_m = 0.0005;
  /// Drift model of the input trajectory: the relative motion between two
  /// nodes d metres apart has standard deviation sqrt(min^2 + drift^2 d) in
  /// translation [m/sqrt(m)] and rotation [deg/sqrt(m)].
  double drift_m_per_sqrt_m = 0.01;
  double drift_deg_per_sqrt_m = 0.2;
  double min_sigma_m = 0.0005;   ///< [m]
  double min_sigma_deg = 0.005;  ///< [deg]
  /// Where the input's samples are more than twice node_interval_s apart (a
  /// keyframe trajectory, a slow odometry) and not a gap, nodes are added between them every
  /// node_interval_s, started on the input's interpolation, and the motion
  /// through them is held smooth: its velocity and angular rate are random
  /// walks of these sigmas per sqrt(second) (a white-noise acceleration),
  /// over every three consecutive nodes with an added one among them
  /// [m/s/sqrt(s)], [deg/s/sqrt(s)]. The samples' own relative motion keeps
  /// the drift model. With estimate_drift_model the data scale both (two
  /// more groups). ORB-SLAM's keyframes on a tripled hand-held path: the
  /// true path given at the keyframes alone registered 3.3x off its floor
  /// without the added nodes and with a 0.5 s gap limit (doc/benchmarks.md,
  /// "Real drift").
  double between_samples_velocity_walk_mps_per_sqrt_s = 0.1;
  double between_samples_rate_walk_dps_per_sqrt_s = 10.0;
  /// Anisotropy of the drift model, in the trajectory's body frame (z up):
  /// the vertical translation's sigma is `drift_vertical_ratio` times the
  /// horizontal's, roll's and pitch's `drift_tilt_ratio` times yaw's. A ground
  /// robot's wheel odometry drifts mostly in the plane and in yaw.
  double drift_vertical_ratio = 1.0;
  double drift_tilt_ratio = 1.0;
  /// Estimate the drift model from the data: factors on the sigmas above for
  /// the horizontal translation, the vertical, the tilt and yaw (and on the
  /// velocity and rate walks between samples, where nodes are added), by variance
  /// component estimation after a round (each update one covariance and one
  /// more round; Observability::drift_model). For an odometry whose drift is
  /// not known, the usual case (lookboth's own VO on the rendered scenarios is
  /// 2-4x looser than the sigmas above, the simulator's wheel odometry 6-8x
  /// tighter): the result is as if the model had been declared. On by default
  /// for that reason (doc/benchmarks-history.md, "The drift model estimated by default").
  bool estimate_drift_model = true;
  int drift_model_updates = 4;  ///< At most this many updates (and extra rounds).
  /// A round followed by another drift model update (its solution only
  /// prepares the update's residuals) uses at most this many blob residuals
  /// per camera (0 = max_blobs_per_camera); after the first update such a
  /// round also stops after this many Levenberg-Marquardt steps (0 =
  /// early_round_max_iterations) and outliers are not judged on its
  /// estimate. The first round converges; the round after the last update
  /// runs with everything to convergence, and its outliers are judged again.
  int drift_round_max_blobs_per_camera = 60;
  int drift_round_max_iterations = 1;
  /// The trajectory's scale is one parameter per segment of this length [m]
  /// (visual: VO's slowly varying scale; metric: the odometry's distance error).
  double scale_segment_m = 10;
  /// Random walk of the scale between consecutive segments (relative, per segment).
  double scale_walk_sigma = 0.002;
  /// Metric mode only: prior of every segment's scale around 1 (relative sigma).
  double metric_scale_sigma = 0.01;
  /// Keep the trajectory (scaled by motion_calibration's scale) fixed: the floor
  /// "given the trajectory", e.g. with a ground-truth trajectory.
  bool fix_trajectory = false;
  // --- fisheye_from_marker ---
  bool fix_fisheye_from_marker = false;
  /// Benchmarks only: start from (with fix_fisheye_from_marker: keep) the
  /// dataset's ground-truth fisheye_from_marker; an error when it has none.
  bool fisheye_from_marker_from_ground_truth = false;
  /// Components motion_calibration reported as not determined by the motion are
  /// tied to its (prior) value with these sigmas [m], [deg].
  double prior_translation_sigma_m = 0.005;
  double prior_rotation_sigma_deg = 2.0;
  /// A component of fisheye_from_marker whose posterior sigma exceeds these, or
  /// that its prior fixes, is reported as not determined [m], [deg].
  double max_translation_sigma_m = 0.002;
  double max_rotation_sigma_deg = 0.5;
  // --- clocks ---
  /// Estimate each camera's clock offset (node clock - robot clock), starting
  /// from associate's configured offset, with a prior around it [s]: the
  /// synchronisation the nodes are known to have. The default is the paper's
  /// NTP: each node within 1-2 ms of the server, so a camera about 2 ms from
  /// the robot. A weaker prior lets a real odometry's error along the path
  /// pass for clock offsets of tens of ms, turning the cameras
  /// (doc/benchmarks.md, "Real drift"); cameras not synchronised need 1.0 or
  /// their offsets in associate.clock_offsets_ns.
  bool estimate_clock_offsets = true;
  double clock_prior_sigma_s = 0.002;
  /// The prior of a camera whose clock is not synchronised: the clock search
  /// moved it by 10 ms or more, the solve took a restarted camera 5 ms or
  /// more from its configured offset, or an earlier run (`register
  /// --update`) found it that far off [s].
  double unsynchronised_clock_prior_sigma_s = 1.0;
  /// An offset whose sigma exceeds this is a warning [ms]: a third of a
  /// 30 Hz frame period, beyond which the detections' times are uncertain
  /// by more than the camera's own sampling.
  double max_clock_sigma_ms = 10.0;
  // --- marker detections ---
  /// Use the four corners (reprojected through the camera's model) when the
  /// detection has them, a corner sigma and the camera a calibration; else the pose.
  bool use_corners = true;
  /// Huber threshold on the norm of a detection's whitened residual [sigmas]:
  /// Ceres applies it to the squared norm, a chi-square with 6 (pose) or 8
  /// (corners) dof, so it must sit above that distribution's bulk: 4.5 = the
  /// square root of chi-square 8 dof at 99 % (6 dof: 4.1). A threshold of 3
  /// down-weighted 17 % (6 dof) and 34 % (8 dof) of clean detections, an
  /// iteratively reweighted fit of the inliers that made large problems' last
  /// round creep (doc/benchmarks-history.md, "Robust losses").
  double huber = 4.5;
  /// Detections whose whitened squared residual exceeds these are rejected
  /// (chi-square 99.9 %: 6 dof for poses, 8 for corners).
  double reject_chi2_pose = 22.46;
  double reject_chi2_corners = 26.12;
  /// Between rounds, scale the marker measurements' covariance (pose and
  /// corners apart) by the median chi-square over its expected value, when
  /// above 1: the detector's covariance leaves out what the model does not
  /// hold (the trajectory between nodes), and rejecting against it alone
  /// throws good detections away. Reported in the warnings.
  bool estimate_variance_factor = true;
  /// The share of a marker detection's error (of its covariance) that the
  /// other detections of its pass share (its camera's detections with no gap
  /// over pass_gap_s): the part of the detector's and the camera model's
  /// error that the viewing geometry sets, which does not average out over a
  /// pass and which the residuals cannot show (the camera's pose absorbs
  /// it). The cameras' covariance counts it (a sandwich over the passes, in
  /// computePassCovariance); the estimate is unchanged. 0: independent
  /// detections. Measured by `lookboth detect --evaluate` on rendered
  /// recordings (doc/benchmarks-history.md, "Marker detection: errors a pass shares").
  double pass_error_share = 0.15;
  /// The same for the blobs of a camera's housing in the fisheye's frames,
  /// relative to blob_sigma_px's variance: most of a rendered blob's error is
  /// where the housing's image sits (0.2-0.3 px), not its noise.
  double blob_pass_error_share = 0.06;
  double pass_gap_s = 1.0;  ///< A longer gap between a camera's detections starts a pass [s].
  /// Carry the shared errors through the whole problem: a pass's error acts
  /// as a perturbation of its camera's pose that also moves the trajectory
  /// under the pass, which carries it to the other cameras (the sandwich
  /// H^-1 M H^-1 over every parameter, computeSharedErrorSpread), when the
  /// cameras' columns of H^-1 are kept (aligned_uncertainty_max_cameras, the
  /// covariance's memory limit); else, or when false, each camera's
  /// covariance gains the shares given the trajectory, which misses that
  /// route: joint_test's shared marker biases gave NEES/dof 1.50 given the
  /// trajectory, 1.18 through it; the rendered `small` (our VO) 2.55 and 1.27
  /// (doc/benchmarks.md, "Real drift").
  bool shared_errors_through_trajectory = true;
  /// Marker pose noise for detections without an information matrix [m], [deg].
  double default_translation_sigma_m = 0.01;
  double default_rotation_sigma_deg = 2.0;
  int min_detections = 3;  ///< Fewer used detections: the camera is unregistered.
  // --- blobs ---
  bool use_blobs = true;
  double blob_sigma_px = 1.0;  ///< Noise of a blob centre [px].
  /// Cauchy scale on the norm of a blob's whitened residual (2 dof) [sigmas]:
  /// a residual at this norm gets half the weight, which 13.5 % of clean
  /// 1-sigma blobs reach. Kept below the chi-square 99 % point (3.0): the
  /// rendered blobs' errors are heavier-tailed than blob_sigma_px says, and
  /// 3.0 made the rendered `revisit` 12.7 -> 16.4 mm (doc/benchmarks-history.md,
  /// "Robust losses").
  double cauchy = 2.0;
  double gate_px = 10;           ///< Nearest blob within this distance of the projection [px]...
  double ambiguity_ratio = 1.5;  ///< ...and the second nearest this many times farther (both ways).
  int association_frame_step = 1;  ///< Associate blobs of every n-th fisheye frame.
  int max_blobs_per_camera = 500;  ///< Blob residuals per camera, spread in time (0 = all).
  int min_blobs = 5;               ///< Fewer associated blobs: the camera's blobs are not used.
  Eigen::Vector3d blob_offset_in_camera_m = Eigen::Vector3d::Zero();  ///< As look_up's [m].
  // --- solver ---
  int rounds = 3;  ///< Association (detections' node brackets, blobs, outliers) + solve rounds.
  int max_iterations = 50;
  /// Iterations of each round before the last (0 = max_iterations): those
  /// rounds only prepare the next association, outlier rejection and
  /// weights, and a round that stops here is never the last one run.
  int early_round_max_iterations = 10;
  /// A round stops when an iteration changes the cost by less than this
  /// fraction (Ceres' function_tolerance).
  double function_tolerance = 1e-5;
  /// Levenberg-Marquardt's first trust-region radius (the inverse of its
  /// first damping; Ceres' default is 1e4). The problem starts near its
  /// solution (the paper's stages) and is nearly quadratic there, so a large
  /// radius takes Gauss-Newton steps from the start, and the long trajectory's
  /// weakly determined bending converges in a few iterations instead of
  /// waiting for the damping to shrink. A step that fails shrinks it anyway.
  double initial_trust_region_radius = 1e10;
  /// "sparse_normal_cholesky", "sparse_schur" or "iterative_schur". CHOLMOD's
  /// supernodal factorisation of the whole J^T J, once it runs on one thread
  /// (core/threads.h), is faster than Ceres' Schur complement, whose reduced
  /// matrix is sorted anew at every step: 43 cameras 0.80x, 300 0.73x,
  /// 1,000 0.88x the time, same results (doc/benchmarks-history.md, "The linear solver").
  std::string linear_solver = "sparse_normal_cholesky";
  /// With sparse_normal_cholesky, the elimination order of J^T J, chosen
  /// afresh for each round on its pattern of parameter blocks: "amd" (Ceres'
  /// own approximate minimum degree), "nested_dissection" (METIS) or "auto"
  /// (nested dissection when the block pattern's symbolic factorisation
  /// predicts it needs under 0.6x AMD's flops; fill_reducing_ordering.h).
  /// The trajectory is a long chain tied to the cameras over it: with all
  /// blobs, nested dissection's factor takes about a third of AMD's flops on
  /// `paper_det` (doc/benchmarks-history.md, "The elimination order of J^T J").
  std::string fill_reducing_ordering = "auto";
  /// Per-camera 6x6 covariance (sparse LDL^T of the problem's J^T J;
  /// lookboth/solver/sparse_covariance.h).
  bool covariance = true;
  /// Also every pair of cameras' poses, for the position RMSE predicted after
  /// a rigid alignment (Observability::aligned_position_rmse_m), when at most
  /// this many cameras are registered (0 = never): those pairs are a dense
  /// matrix, its cost grows like the cube of the cameras.
  int aligned_uncertainty_max_cameras = 200;
  int threads = 1;
  /// Sets the options `node` (the configuration's "register.<stage>" section,
  /// named `field` in errors) has; an unknown key is an error.
  void read(const YamlReader& reader, const YAML::Node& node, const std::string& field);
  /// Every option under its key, as read() reads them.
  void write(YAML::Node& node) const;
  std::string check() const;
};

void runJoint(RegistrationProblem& problem, const JointOptions& options,
              const ProgressReporter& progress);

}  // namespace lookboth
