// `lookboth report`: one self-contained HTML file (pictures embedded as
// base64 PNG, no script, no external resource) that a customer opens offline:
// the verdict, the per-camera table, the paper-style tables (reprojection
// before/after; comparison with ground truth or another run) and the
// pictures of `lookboth snapshot`.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "lookboth/core/progress.h"
#include "lookboth/registration/facility_check.h"
#include "lookboth/report/snapshot.h"

namespace lookboth::report {

struct ReportOptions {
  std::filesystem::path out;           ///< The HTML file to write.
  std::filesystem::path ground_truth;  ///< Dataset, folder or cameras.csv; empty = none.
  std::filesystem::path against;       ///< Another registration directory; empty = none.
  /// The registration on record for this facility: the report re-checks this
  /// drive against it (which cameras moved; `lookboth check`); empty = none.
  std::filesystem::path record;
  FacilityCheckOptions recheck;  ///< How a move is told from noise (with `record`).
  bool with_scale = false;       ///< Sim(3) alignment for the comparisons.
  FrameSelection frames;         ///< Fisheye frames to show.
  cv::Size size{0, 0};           ///< Picture size (see SnapshotOptions::size).
  int auto_frames = 4;           ///< Fisheye frames picked automatically.
  int max_env_views = 6;         ///< Environment camera pictures at most.
  bool overview = true;          ///< The 3-D overview (needs EGL).
  /// Verdict thresholds. Reprojection RMS after refinement [px]; 0 = 3 px
  /// at 1920 px of fisheye width, scaled to the fisheye's width, but not
  /// below 2 px (blob centres are not located better at low resolution).
  double max_reprojection_rms_px = 0;
  double max_position_sigma_m = 0.05;   ///< 1-sigma position uncertainty of a camera [m].
  double max_position_error_m = 0.10;   ///< Against ground truth: position RMS [m].
  double max_rotation_error_deg = 1.0;  ///< Against ground truth: rotation RMS [deg].
  /// Against ground truth: the positions' NEES per degree of freedom
  /// (PoseComparison::position_nees_per_dof) above which the registration's
  /// predicted uncertainty is too small to trust [-]. 2 leaves room for the
  /// spread of a few dozen cameras' NEES around 1.
  double max_position_nees_per_dof = 2.0;
  std::string check() const;
};

enum class Verdict { kOk, kNeedsChecking, kFailed };
/// "ok", "needs checking", "failed".
const char* verdictName(Verdict verdict);

struct ReportSummary {
  Verdict verdict = Verdict::kFailed;
  std::vector<std::string> reasons;  ///< Why not ok (empty when it is).
  int pictures = 0;
  std::uintmax_t bytes = 0;  ///< Size of the HTML file.
};

/// Writes the report (atomically). Throws lookboth::Error on bad input,
/// StopRequested when stopped.
ReportSummary writeReport(const std::filesystem::path& dataset,
                          const std::filesystem::path& registration_dir,
                          const ReportOptions& options, const ProgressReporter& progress);

/// RFC 4648 base64 of bytes.
std::string base64(const std::vector<unsigned char>& bytes);

}  // namespace lookboth::report
