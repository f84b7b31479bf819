#include "lookboth/report/report.h"

#include <unistd.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>

#include "lookboth/core/atomic_file.h"
#include "lookboth/core/error.h"
#include "lookboth/core/temporary_files.h"
#include "lookboth/core/text.h"
#include "lookboth/core/version.h"
#include "lookboth/dataset/dataset_io.h"
#include "lookboth/registration/registration.h"

namespace lookboth::report {
namespace fs = std::filesystem;

const char* verdictName(Verdict verdict) {
  switch (verdict) {
    case Verdict::kOk:
      return "ok";
    case Verdict::kNeedsChecking:
      return "needs checking";
    case Verdict::kFailed:
      return "failed";
  }
  return "?";
}

std::string ReportOptions::check() const {
  if (out.empty()) return "'out': the HTML file to write is required";
  if (max_reprojection_rms_px < 0) return "'max_reprojection_rms_px': must be >= 0";
  if (!(max_position_sigma_m > 0)) return "'max_position_sigma_m': must be positive";
  if (!(max_position_nees_per_dof > 0)) return "'max_position_nees_per_dof': must be positive";
  if (auto_frames < 1) return "'auto_frames': must be at least 1";
  if (max_env_views < 0) return "'max_env_views': must be >= 0";
  if (!record.empty()) {
    if (const std::string why = recheck.check(); !why.empty()) return "'recheck': " + why;
  }
  return {};
}

std::string base64(const std::vector<unsigned char>& bytes) {
  static const char* kAlphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  size_t i = 0;
  for (; i + 2 < bytes.size(); i += 3) {
    const unsigned v = (bytes[i] << 16) | (bytes[i + 1] << 8) | bytes[i + 2];
    out += kAlphabet[(v >> 18) & 63];
    out += kAlphabet[(v >> 12) & 63];
    out += kAlphabet[(v >> 6) & 63];
    out += kAlphabet[v & 63];
  }
  if (i + 1 == bytes.size()) {
    const unsigned v = bytes[i] << 16;
    out += kAlphabet[(v >> 18) & 63];
    out += kAlphabet[(v >> 12) & 63];
    out += "==";
  } else if (i + 2 == bytes.size()) {
    const unsigned v = (bytes[i] << 16) | (bytes[i + 1] << 8);
    out += kAlphabet[(v >> 18) & 63];
    out += kAlphabet[(v >> 12) & 63];
    out += kAlphabet[(v >> 6) & 63];
    out += '=';
  }
  return out;
}

namespace {

std::string escape(const std::string& text) {
  std::string out;
  for (char c : text) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

/// A titled list of messages; nothing when there are none.
void writeMessages(std::ostream& out, const std::string& title, const std::string& what,
                   const std::vector<std::string>& items) {
  if (items.empty()) return;
  out << "<h2>" << escape(title) << "</h2>\n<p class=note>" << escape(what) << "</p>\n<ul>";
  for (const std::string& item : items) out << "<li>" << escape(item) << "</li>";
  out << "</ul>\n";
}

std::string fixed(double value, int decimals) { return formatFixed(value, decimals); }

/// A plan view (x right, y up) of the control points with their residuals
/// as arrows, magnified so that the largest is a tenth of the site's extent.
std::string controlPointSvg(const std::vector<ControlPointFit>& points) {
  Eigen::Vector2d lo(1e300, 1e300), hi(-1e300, -1e300);
  double largest = 0;
  for (const ControlPointFit& p : points) {
    lo = lo.cwiseMin(p.p_in_site.head<2>());
    hi = hi.cwiseMax(p.p_in_site.head<2>());
    largest = std::max(largest, p.residual_m.head<2>().norm());
  }
  const double extent = std::max({hi.x() - lo.x(), hi.y() - lo.y(), 1.0});
  const double size = 480, margin = 40, scale = (size - 2 * margin) / extent;
  const double magnify = largest > 0 ? 0.1 * extent / largest : 1.0;
  auto x = [&](double v) { return fixed(margin + (v - lo.x()) * scale, 1); };
  auto y = [&](double v) { return fixed(size - margin - (v - lo.y()) * scale, 1); };
  std::ostringstream svg;
  svg << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << size << "\" height=\"" << size
      << "\" viewBox=\"0 0 " << size << " " << size
      << "\"><rect width=\"100%\" height=\"100%\" fill=\"#fff\" stroke=\"#999\"/>";
  for (const ControlPointFit& p : points) {
    const Eigen::Vector2d a = p.p_in_site.head<2>();
    const Eigen::Vector2d b = a - magnify * p.residual_m.head<2>();  // where the registration is
    svg << "<line x1=\"" << x(a.x()) << "\" y1=\"" << y(a.y()) << "\" x2=\"" << x(b.x())
        << "\" y2=\"" << y(b.y()) << "\" stroke=\"" << (p.sigmas > 3 ? "#c00" : "#06c")
        << "\" stroke-width=\"2\"/><circle cx=\"" << x(a.x()) << "\" cy=\"" << y(a.y())
        << "\" r=\"3\"/><text x=\"" << x(a.x()) << "\" y=\"" << y(a.y()) << "\" dy=\"-5\" "
        << (a.x() > 0.5 * (lo.x() + hi.x()) ? "dx=\"-5\" text-anchor=\"end\"" : "dx=\"5\"")
        << " font-size=\"11\">" << escape(p.name) << "</text>";  // labels stay inside
  }
  svg << "</svg>";
  return svg.str() + "<p class=note>Plan view: each surveyed point (dot) and the registration's " +
         "camera (end of the line), the difference magnified " + fixed(magnify, 0) +
         "x; red over 3 sigmas.</p>\n";
}

/// 1-sigma along the worst direction of a 3x3 block of a covariance.
double worstSigma(const Eigen::Matrix3d& covariance) {
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(covariance);
  return std::sqrt(std::max(0.0, solver.eigenvalues().maxCoeff()));
}

const char* kStyle = R"(
body { font-family: "DejaVu Sans", Arial, sans-serif; margin: 24px; color: #222; max-width: 1400px; }
h1 { font-size: 24px; margin-bottom: 4px; }
h2 { font-size: 19px; margin-top: 28px; border-bottom: 1px solid #ccc; padding-bottom: 3px; }
.verdict { padding: 14px 18px; border-radius: 6px; font-size: 20px; font-weight: bold; color: #fff; }
.ok { background: #1e8f3a; } .needs-checking { background: #d9822b; } .failed { background: #c0392b; }
.reasons { margin: 8px 0 0 0; font-size: 14px; font-weight: normal; }
table { border-collapse: collapse; font-size: 13px; margin: 8px 0; }
th, td { border: 1px solid #bbb; padding: 3px 7px; text-align: right; }
th { background: #eee; } td.l, th.l { text-align: left; }
tr.suspect td { background: #fdf0dc; } tr.unregistered td { background: #f8dcd9; }
.meta td { text-align: left; border: none; padding: 1px 10px 1px 0; }
figure { display: inline-block; margin: 8px; vertical-align: top; max-width: 100%; }
figure img { max-width: 100%; border: 1px solid #999; }
figcaption { font-size: 13px; max-width: 900px; }
.note { font-size: 13px; color: #555; }
)";

struct Section {
  std::ostringstream html;
};

void comparisonTables(std::ostringstream& out, const PoseComparison& c, const std::string& what) {
  out << "<p>" << escape(what) << ": aligned by " << (c.with_scale ? "Sim(3)" : "SE(3)")
      << " (Umeyama over " << c.cameras.size() << " camera positions";
  if (c.with_scale) out << ", scale " << fixed(c.reference_from_estimate.scale, 6);
  out << "). Differences are estimate minus reference in the reference's world axes; roll, "
         "pitch and yaw are rotations about its x, y and z (vertical) axes.</p>\n";
  out << "<table><tr><th class=l></th><th>&phi; roll [&deg;]</th><th>&theta; pitch [&deg;]</th>"
         "<th>&psi; yaw [&deg;]</th><th>X [m]</th><th>Y [m]</th><th>Z [m]</th>"
         "<th>position [m]</th><th>rotation [&deg;]</th></tr>\n";
  out << "<tr><td class=l>RMS</td><td>" << fixed(c.rms.roll_pitch_yaw_deg.x(), 4) << "</td><td>"
      << fixed(c.rms.roll_pitch_yaw_deg.y(), 4) << "</td><td>"
      << fixed(c.rms.roll_pitch_yaw_deg.z(), 4) << "</td><td>" << fixed(c.rms.position_m.x(), 4)
      << "</td><td>" << fixed(c.rms.position_m.y(), 4) << "</td><td>"
      << fixed(c.rms.position_m.z(), 4) << "</td><td>" << fixed(c.rms.position_m_total, 4)
      << "</td><td>" << fixed(c.rms.rotation_deg_total, 4) << "</td></tr>\n";
  out << "<tr><td class=l>max</td><td></td><td></td><td></td><td></td><td></td><td></td><td>"
      << fixed(c.rms.position_m_max, 4) << "</td><td>" << fixed(c.rms.rotation_deg_max, 4)
      << "</td></tr></table>\n";
  if (c.position_nees_per_dof) {
    out << "<p>Position NEES per degree of freedom: " << fixed(*c.position_nees_per_dof, 2)
        << " (the differences measured against the registration's own predicted error; near 1 "
           "when that prediction is honest, above when it is too small).</p>\n";
  }
  if (!c.missing_in_estimate.empty()) {
    out << "<p class=note>Not registered, not counted:";
    for (const auto& label : c.missing_in_estimate) out << " " << escape(label);
    out << "</p>\n";
  }
}

// writeReport's steps: the inputs and comparisons, the verdict, the
// pictures, then the page section by section.
class ReportWriter {
 public:
  ReportWriter(const fs::path& dataset, const fs::path& registration_dir,
               const ReportOptions& options)
      : dataset_(dataset),
        registration_dir_(registration_dir),
        options_(options),
        registration_(loadRegistration(registration_dir)),
        view_(viewOfRegistration(registration_, "registration")) {}

  ReportSummary write(const ProgressReporter& progress) {
    compare();
    judge();
    renderPictures(progress);
    progress.report("report: write", 0, 1);
    writeHeader();
    writeVerdict();
    writeCameraTable();
    writeWorldFrame();
    writeReprojectionTable();
    writeComparisons();
    writeRecheck();
    writeRobot();
    writeRunTime();
    writePictures();
    const std::string html = out_.str();
    writeFileAtomically(options_.out, html);
    summary_.bytes = html.size();
    progress.report("report: write", 1, 1);
    return summary_;
  }

 private:
  /// The comparisons with ground truth and another registration, the
  /// reprojection table, and the reprojection bound for the fisheye's width.
  void compare() {
    const CompareOptions compare{options_.with_scale};
    const CameraPoseSet estimate = poseSetOfRegistration(registration_, registration_dir_.string());
    if (!options_.ground_truth.empty()) {
      truth_poses_ = loadGroundTruthPoses(options_.ground_truth);
      ground_truth_ = comparePoses(*truth_poses_, estimate, compare);
    }
    if (!options_.against.empty()) {
      other_poses_ =
          poseSetOfRegistration(loadRegistration(options_.against), options_.against.string());
      against_ = comparePoses(*other_poses_, estimate, compare);
    }
    if (!options_.record.empty()) {
      recheck_ = checkFacility(registration_, loadRegistration(options_.record), options_.recheck);
    }
    reprojection_ = reprojectionTable(view_.blob_associations);
    int fisheye_width = 1920;
    DatasetReadOptions read_options;
    read_options.check_images = false;
    const auto reader = DatasetReader::open(dataset_, read_options);
    if (const CameraSensor* fisheye = reader->manifest().fisheye(); fisheye && fisheye->camera) {
      fisheye_width = fisheye->camera->width();
    }
    max_reprojection_ = options_.max_reprojection_rms_px > 0
                            ? options_.max_reprojection_rms_px
                            : std::max(2.0, 3.0 * fisheye_width / 1920.0);
  }

  /// The verdict and its reasons.
  void judge() {
    std::vector<std::string>& reasons = summary_.reasons;
    const Registration& registration = registration_;
    const auto& options = options_;
    const auto& reprojection = reprojection_;
    const auto& ground_truth = ground_truth_;
    const double max_reprojection = max_reprojection_;
    const int registered = registration.registeredCount();
    int suspect = 0, unregistered = 0, uncertain = 0;
    for (const CameraRegistration& c : registration.cameras) {
      if (c.status == CameraStatus::kSuspect) ++suspect;
      if (c.status == CameraStatus::kUnregistered) ++unregistered;
      if (c.status != CameraStatus::kUnregistered && c.covariance &&
          worstSigma(c.covariance->topLeftCorner<3, 3>()) > options.max_position_sigma_m) {
        ++uncertain;
      }
    }
    if (registered == 0) reasons.push_back("no camera could be registered");
    if (unregistered) reasons.push_back(std::to_string(unregistered) + " camera(s) not registered");
    if (suspect) reasons.push_back(std::to_string(suspect) + " camera(s) suspect");
    if (uncertain) {
      reasons.push_back(std::to_string(uncertain) +
                        " camera(s) with a position uncertainty above " +
                        fixed(options.max_position_sigma_m * 1000, 0) + " mm (1 sigma)");
    }
    if (reprojection.total.blobs_after > 0 && reprojection.total.rms_px_after > max_reprojection) {
      reasons.push_back("fisheye reprojection RMS after refinement " +
                        fixed(reprojection.total.rms_px_after, 2) + " px exceeds " +
                        fixed(max_reprojection, 2) + " px");
    }
    if (reprojection.total.blobs_before > 0 && reprojection.total.blobs_after > 0 &&
        reprojection.total.rms_px_after > reprojection.total.rms_px_before) {
      reasons.push_back("the refinement increased the reprojection error");
    }
    if (ground_truth && ground_truth->rms.position_m_total > options.max_position_error_m) {
      reasons.push_back("position RMS against ground truth " +
                        fixed(ground_truth->rms.position_m_total, 3) + " m exceeds " +
                        fixed(options.max_position_error_m, 3) + " m");
    }
    if (ground_truth && ground_truth->rms.rotation_deg_total > options.max_rotation_error_deg) {
      reasons.push_back("rotation RMS against ground truth " +
                        fixed(ground_truth->rms.rotation_deg_total, 2) + " deg exceeds " +
                        fixed(options.max_rotation_error_deg, 2) + " deg");
    }
    if (ground_truth && ground_truth->position_nees_per_dof &&
        *ground_truth->position_nees_per_dof > options.max_position_nees_per_dof) {
      reasons.push_back(
          "the predicted uncertainty is too small: position NEES per degree of "
          "freedom " +
          fixed(*ground_truth->position_nees_per_dof, 2) + " against ground truth (above " +
          fixed(options.max_position_nees_per_dof, 1) + ")");
    }
    if (recheck_ && recheck_->moved > 0) {
      reasons.push_back(std::to_string(recheck_->moved) +
                        " camera(s) moved since the record (see Re-check); lookboth check "
                        "--update-out writes the record updated by this drive");
    }
    // Notes (a prior held what a flat floor cannot determine, detections set
    // aside at the ends) are expected and leave the verdict alone.
    if (const std::size_t warnings = registration.labelledWarnings().size(); warnings > 0) {
      reasons.push_back(std::to_string(warnings) + " warning(s) to act on (see Warnings)");
    }
    summary_.verdict = registered == 0   ? Verdict::kFailed
                       : reasons.empty() ? Verdict::kOk
                                         : Verdict::kNeedsChecking;
  }

  /// The pictures, in a temporary folder beside the output (embedded, then removed).
  void renderPictures(const ProgressReporter& progress) {
    const fs::path out_dir = fs::absolute(options_.out).parent_path();
    if (!fs::is_directory(out_dir)) {
      throw Error({options_.out.string(), 0, "", ""}, "the output's folder does not exist");
    }
    static int counter = 0;
    removeStaleTemporaries(out_dir);
    const fs::path pictures_dir = out_dir / (".lookboth-report-" + std::to_string(::getpid()) +
                                             "-" + std::to_string(counter++));
    struct RemoveDir {
      fs::path dir;
      ~RemoveDir() {
        std::error_code ec;
        fs::remove_all(dir, ec);
      }
    } remove_dir{pictures_dir};
    SnapshotOptions snapshot;
    snapshot.out = pictures_dir;
    snapshot.frames = options_.frames;
    snapshot.size = options_.size;
    snapshot.auto_frames = options_.auto_frames;
    snapshot.max_env_views = options_.max_env_views;
    snapshot.overview = options_.overview;
    if (truth_poses_) snapshot.references.push_back({"ground_truth", *truth_poses_});
    if (other_poses_) {
      const std::string name = fs::path(options_.against).lexically_normal().filename().string();
      snapshot.references.push_back({name.empty() ? "other" : name, *other_poses_});
    }
    snapshot.reference_with_scale = options_.with_scale;
    pictures_ = writeSnapshots(dataset_, view_, snapshot, progress);
    // Read now: the folder is removed on return.
    for (const SnapshotPicture& picture : pictures_.pictures) {
      std::ifstream in(picture.file, std::ios::binary);
      picture_bytes_.emplace_back((std::istreambuf_iterator<char>(in)),
                                  std::istreambuf_iterator<char>());
    }
    summary_.pictures = static_cast<int>(pictures_.pictures.size());
  }

  void writeHeader() {
    std::ostringstream& out = out_;
    const Registration& registration = registration_;
    out << "<!DOCTYPE html>\n<html lang=en><head><meta charset=utf-8>\n"
           "<title>lookboth registration report</title>\n<style>"
        << kStyle << "</style></head><body>\n";
    out << "<h1>Camera registration report</h1>\n";
    out << "<table class=meta>";
    out << "<tr><td>dataset</td><td>"
        << escape(registration.dataset.empty() ? dataset_.string() : registration.dataset)
        << "</td></tr>";
    out << "<tr><td>registration</td><td>" << escape(fs::absolute(registration_dir_).string())
        << " (created " << escape(registration.created) << ")</td></tr>";
    out << "<tr><td>pipeline</td><td>";
    for (size_t i = 0; i < registration.pipeline.size(); ++i) {
      out << (i ? " &rarr; " : "") << escape(registration.pipeline[i]);
    }
    out << "</td></tr>";
    out << "<tr><td>trajectory</td><td>" << trajectoryModeName(registration.trajectory_mode) << " ("
        << escape(registration.trajectory_label) << "), scale " << fixed(registration.scale, 5);
    if (registration.scale_sigma > 0) out << " &plusmn; " << fixed(registration.scale_sigma, 5);
    out << "</td></tr>";
    out << "<tr><td>versions</td><td>lookboth " << escape(versionString());
    for (const auto& [name, version] : registration.versions) {
      if (name != "lookboth") out << ", " << escape(name) << " " << escape(version);
    }
    out << "</td></tr></table>\n";
  }

  void writeVerdict() {
    std::ostringstream& out = out_;
    const Registration& registration = registration_;
    const std::vector<std::string>& reasons = summary_.reasons;
    const int registered = registration.registeredCount();
    const std::string verdict_class = summary_.verdict == Verdict::kOk ? "ok"
                                      : summary_.verdict == Verdict::kNeedsChecking
                                          ? "needs-checking"
                                          : "failed";
    out << "<div class=\"verdict " << verdict_class
        << "\">Verdict: " << escape(verdictName(summary_.verdict)) << " &mdash; " << registered
        << " of " << registration.cameras.size() << " cameras registered";
    if (reasons.empty()) {
      out << "<div class=reasons>Every camera registered, no warning, reprojection after "
             "refinement "
             "within "
          << fixed(max_reprojection_, 2) << " px"
          << (ground_truth_ ? ", within the ground truth bounds" : "") << ".</div>";
    } else {
      out << "<ul class=reasons>";
      for (const std::string& reason : reasons) out << "<li>" << escape(reason) << "</li>";
      out << "</ul>";
    }
    out << "</div>\n";
  }

  /// One row of the per-camera table.
  void writeCameraRow(const CameraRegistration& c) {
    std::ostringstream& out = out_;
    const auto& reprojection = reprojection_;
    const auto& ground_truth = ground_truth_;
    out << "<tr class=" << cameraStatusName(c.status) << "><td class=l>" << escape(c.label)
        << "</td><td class=l>" << cameraStatusName(c.status) << "</td><td>" << c.detections.used
        << " / " << c.detections.total << "</td><td>" << c.detections.rejected << "</td><td>"
        << c.detections.outside_trajectory << "</td>";
    if (c.residuals) {
      out << "<td>" << fixed(c.residuals->position_rms_m * 1000, 1) << "</td><td>"
          << fixed(c.residuals->rotation_rms_deg, 3) << "</td>";
    } else {
      out << "<td></td><td></td>";
    }
    const auto table_row = reprojection.by_camera.find(c.label);
    if (table_row != reprojection.by_camera.end()) {
      const ReprojectionSummary& r = table_row->second;
      out << "<td>" << r.blobs << "</td><td>" << (r.blobs_before ? fixed(r.rms_px_before, 2) : "")
          << "</td><td>" << (r.blobs_after ? fixed(r.rms_px_after, 2) : "") << "</td>";
    } else if (c.reprojection) {
      out << "<td>" << c.reprojection->blobs << "</td><td>"
          << fixed(c.reprojection->rms_px_before, 2) << "</td><td>"
          << fixed(c.reprojection->rms_px_after, 2) << "</td>";
    } else {
      out << "<td>0</td><td></td><td></td>";
    }
    if (c.covariance && c.status != CameraStatus::kUnregistered) {
      out << "<td>" << fixed(worstSigma(c.covariance->topLeftCorner<3, 3>()) * 1000, 2)
          << "</td><td>"
          << fixed(worstSigma(c.covariance->bottomRightCorner<3, 3>()) * 180 / M_PI, 3) << "</td>";
    } else {
      out << "<td></td><td></td>";
    }
    if (c.aligned_position_covariance && c.status != CameraStatus::kUnregistered) {
      out << "<td>"
          << fixed(std::sqrt(std::max(0.0, c.aligned_position_covariance->trace())) * 1000, 2)
          << "</td>";
    } else {
      out << "<td></td>";
    }
    if (ground_truth) {
      const auto d = std::find_if(ground_truth->cameras.begin(), ground_truth->cameras.end(),
                                  [&](const CameraDifference& x) { return x.label == c.label; });
      if (d != ground_truth->cameras.end()) {
        out << "<td>" << fixed(d->position_error_m * 1000, 1) << "</td><td>"
            << fixed(d->rotation_error_deg, 3) << "</td>";
      } else {
        out << "<td></td><td></td>";
      }
    }
    out << "<td class=l>" << escape(c.reason);
    for (const std::string& w : c.warnings) out << (c.reason.empty() ? "" : "; ") << escape(w);
    out << "</td></tr>\n";
  }

  void writeCameraTable() {
    std::ostringstream& out = out_;
    out << "<h2>Cameras</h2>\n<table><tr><th class=l>camera</th><th class=l>status</th>"
           "<th>detections used / total</th><th>rejected</th><th>outside traj.</th>"
           "<th>residual pos. [mm]</th><th>residual rot. [&deg;]</th><th>blobs</th>"
           "<th>reproj. before [px]</th><th>reproj. after [px]</th><th>&sigma; pos. [mm]</th>"
           "<th>&sigma; rot. [&deg;]</th><th>predicted error pos. [mm]</th>";
    if (ground_truth_) out << "<th>error pos. [mm]</th><th>error rot. [&deg;]</th>";
    out << "<th class=l>reason / warnings</th></tr>\n";
    for (const CameraRegistration& c : registration_.cameras) writeCameraRow(c);
    out << "</table>\n<p class=note>&sigma;: one standard deviation along the worst direction, "
           "from the registration's covariance. Predicted error: the root of the trace of the "
           "camera's "
           "position covariance once a rigid alignment over the cameras is projected out, what an "
           "aligned comparison with ground truth should show. Residuals: RMS of the looking-down "
           "residuals of the used detections.</p>\n";
  }

  /// The paper's Table I.
  void writeReprojectionTable() {
    std::ostringstream& out = out_;
    const Registration& registration = registration_;
    const auto& reprojection = reprojection_;
    out << "<h2>Reprojection of the camera positions into the fisheye (paper's Table I)</h2>\n";
    if (reprojection.total.blobs > 0) {
      out << "<table><tr><th class=l></th><th>blobs</th><th>RMSE before refinement [px]</th>"
             "<th>RMSE after refinement [px]</th></tr>\n";
      out << "<tr><td class=l>recomputed from blob_associations.csv</td><td>"
          << reprojection.total.blobs << "</td><td>"
          << (reprojection.total.blobs_before ? fixed(reprojection.total.rms_px_before, 3) : "-")
          << "</td><td>"
          << (reprojection.total.blobs_after ? fixed(reprojection.total.rms_px_after, 3) : "-")
          << "</td></tr>\n";
      if (registration.reprojection) {
        out << "<tr><td class=l>reported by the registration</td><td>"
            << registration.reprojection->blobs << "</td><td>"
            << fixed(registration.reprojection->rms_px_before, 3) << "</td><td>"
            << fixed(registration.reprojection->rms_px_after, 3) << "</td></tr>\n";
      }
      out << "</table>\n";
    } else {
      out << "<p class=note>No blob association: the looking-up stage did not run (no fisheye "
             "blobs, or a metric trajectory without fisheye frames).</p>\n";
    }
  }

  /// The paper's Table II form.
  void writeComparisons() {
    if (!ground_truth_ && !against_) return;
    out_ << "<h2>Comparison (paper's Table II form: RMS differences per axis)</h2>\n";
    if (ground_truth_) {
      comparisonTables(out_, *ground_truth_,
                       "Against ground truth " + options_.ground_truth.string());
    }
    if (against_) {
      comparisonTables(out_, *against_, "Against the registration " + options_.against.string());
    }
  }

  /// This drive against the registration on record: each camera's verdict.
  void writeRecheck() {
    if (!recheck_) return;
    std::ostringstream& out = out_;
    const FacilityCheck& check = *recheck_;
    out << "<h2>Re-check against the record " << escape(options_.record.string()) << "</h2>\n<p>"
        << check.moved << " moved, " << check.unchanged << " unchanged, " << check.not_seen
        << " not seen by this drive, " << check.added
        << " new. The two registrations aligned over the cameras that agree; a camera moved when "
           "its change is significant (chi-square over 3 dof above "
        << fixed(options_.recheck.max_chi2, 2) << ") and larger than "
        << fixed(options_.recheck.min_position_m * 1000, 0) << " mm or "
        << fixed(options_.recheck.min_rotation_deg, 1) << "&deg;.</p>\n";
    out << "<table><tr><th class=l>camera</th><th class=l>verdict</th><th>moved [mm]</th>"
           "<th>sigmas</th><th>turned [&deg;]</th><th>sigmas</th><th class=l>alignment</th>"
           "</tr>\n";
    for (const CameraCheck& c : check.cameras) {
      const bool compared =
          c.verdict == CameraVerdict::kMoved || c.verdict == CameraVerdict::kUnchanged;
      const char* row = c.verdict == CameraVerdict::kMoved     ? " class=unregistered"
                        : c.verdict == CameraVerdict::kNotSeen ? " class=suspect"
                                                               : "";
      out << "<tr" << row << "><td class=l>" << escape(c.label) << "</td><td class=l>"
          << cameraVerdictName(c.verdict) << "</td>";
      if (compared) {
        out << "<td>" << fixed(c.moved_m.norm() * 1000, 1) << "</td><td>"
            << fixed(std::sqrt(c.position_chi2), 1) << "</td><td>" << fixed(c.rotated_deg, 3)
            << "</td><td>" << fixed(std::sqrt(c.rotation_chi2), 1) << "</td>";
      } else {
        out << "<td>-</td><td>-</td><td>-</td><td>-</td>";
      }
      out << "<td class=l>"
          << (c.used_for_alignment ? "used"
              : compared           ? "left out"
                                   : "")
          << "</td></tr>\n";
    }
    out << "</table>\n<p class=note>Sigmas: the square root of the change's chi-square under "
           "both registrations' covariances. Moved cameras are left out of the alignment.</p>\n";
  }

  /// The robot's calibration, observability, warnings and notes.
  /// Which frame the poses are in and, for a site frame, its control points' residuals.
  void writeWorldFrame() {
    std::ostringstream& out = out_;
    const WorldFrame& frame = registration_.world_frame;
    out << "<h2>World frame: " << escape(frame.name) << "</h2>\n<p>" << escape(frame.description)
        << ".</p>\n";
    if (frame.control_points.empty()) return;
    out << "<table><tr><th class=l>control point</th><th>x [m]</th><th>y [m]</th><th>z [m]</th>"
           "<th>dx [mm]</th><th>dy [mm]</th><th>dz [mm]</th><th>|d| "
           "[mm]</th><th>sigmas</th></tr>\n";
    for (const ControlPointFit& p : frame.control_points) {
      out << "<tr" << (p.sigmas > 3 ? " class=unregistered" : "") << "><td class=l>"
          << escape(p.name) << "</td>";
      for (int i = 0; i < 3; ++i) out << "<td>" << fixed(p.p_in_site[i], 3) << "</td>";
      for (int i = 0; i < 3; ++i) out << "<td>" << fixed(p.residual_m[i] * 1000, 1) << "</td>";
      out << "<td>" << fixed(p.residual_m.norm() * 1000, 1) << "</td><td>" << fixed(p.sigmas, 2)
          << "</td></tr>\n";
    }
    out << "</table>\n" << controlPointSvg(frame.control_points);
  }

  void writeRobot() {
    std::ostringstream& out = out_;
    const Registration& registration = registration_;
    out << "<h2>Robot: fisheye_from_marker</h2>\n<p>translation [m] ("
        << fixed(registration.fisheye_from_marker.translation.x(), 4) << ", "
        << fixed(registration.fisheye_from_marker.translation.y(), 4) << ", "
        << fixed(registration.fisheye_from_marker.translation.z(), 4)
        << "), determined by the data: ";
    const char* names[6] = {"x", "y", "z", "roll", "pitch", "yaw"};
    for (int i = 0; i < 6; ++i) {
      out << names[i] << (registration.fisheye_from_marker_determined[i] ? " yes" : " <b>no</b>")
          << (i < 5 ? ", " : "");
    }
    out << ".";
    if (!registration.fisheye_from_marker_prior.empty()) {
      out << " Prior: " << escape(registration.fisheye_from_marker_prior) << ".";
    }
    out << "</p>\n";
    if (!registration.observability.message.empty()) {
      // One sentence per line: the statement is long.
      std::string text = escape(wrapSentences(registration.observability.message, "", 100000));
      for (std::size_t at = text.find('\n'); at != std::string::npos; at = text.find('\n', at))
        text.replace(at, 1, "<br>");
      out << "<p>" << text << "</p>\n";
    }
    if (registration.observability.aligned_position_rmse_m) {
      out << "<p>Camera positions: the covariance predicts an RMS error of "
          << fixed(*registration.observability.aligned_position_rmse_m * 1000, 2)
          << " mm after a rigid alignment to any reference (a survey, another registration).</p>\n";
    }
    writeMessages(out, "Warnings", "What to act on, and how.", registration.labelledWarnings());
    writeMessages(out, "Notes",
                  "Nothing to act on: what priors held because the data cannot determine it, "
                  "detections set aside, the solver's choices.",
                  registration.labelledNotes());
  }

  /// What the registration took against the drive it processed
  /// (registration.yaml's statistics; the output's own writing not counted).
  void writeRunTime() {
    const RegistrationStatistics& s = registration_.statistics;
    double stages = 0;
    for (const auto& [stage, seconds] : s.seconds_per_stage) stages += seconds;
    double total = stages;
    std::string steps;
    for (const char* step : {"detect", "odometry"}) {
      const auto found = s.seconds_per_step.find(step);
      if (found == s.seconds_per_step.end()) continue;
      steps += std::string(step) + " " + fixed(found->second, 1) + " s, ";
      total += found->second;
    }
    if (!(total > 0)) return;
    std::ostringstream& out = out_;
    out << "<h2>Run time</h2>\n<p>" << steps << "the stages " << fixed(stages, 1)
        << " s: " << fixed(total, 1) << " s in all";
    if (s.drive_seconds > 0) {
      out << ", " << fixed(total / s.drive_seconds, 2) << "x the drive ("
          << fixed(s.drive_seconds, 1) << " s)";
    }
    out << ".</p>\n";
  }

  void writePictures() {
    std::ostringstream& out = out_;
    out << "<h2>Pictures</h2>\n";
    const std::pair<const char*, const char*> groups[] = {
        {"fisheye_check",
         "Reprojection checks on fisheye frames: detected blobs (green rings), camera positions "
         "before (red crosses) and after (blue discs) the looking-up refinement."},
        {"env_view", "Environment cameras' views of the robot's marker."},
        {"overview_3d", "3-D overview."},
        {"compare", "Top and side views against the reference."},
        {"loop_closure", "Trajectory before and after loop closure."}};
    for (const auto& [kind, heading] : groups) {
      bool any = false;
      for (std::size_t k = 0; k < pictures_.pictures.size(); ++k) {
        const SnapshotPicture& picture = pictures_.pictures[k];
        if (picture.kind != kind) continue;
        if (!any) out << "<p>" << heading << "</p>\n";
        any = true;
        out << "<figure><img alt=\"" << escape(picture.file.filename().string())
            << "\" src=\"data:image/png;base64," << base64(picture_bytes_[k]) << "\"><figcaption>"
            << escape(picture.caption) << " <i>(" << escape(picture.file.filename().string())
            << ")</i></figcaption></figure>\n";
      }
    }
    for (const std::string& note : pictures_.notes)
      out << "<p class=note>" << escape(note) << "</p>\n";
    out << "<p class=note>Written by lookboth " << escape(versionString())
        << " (lookboth report). Self-contained: no script, no external resource.</p>\n";
    out << "</body></html>\n";
  }

  const fs::path dataset_, registration_dir_;
  const ReportOptions& options_;
  const Registration registration_;
  const RegistrationView view_;
  std::optional<CameraPoseSet> truth_poses_, other_poses_;
  std::optional<PoseComparison> ground_truth_, against_;
  std::optional<FacilityCheck> recheck_;
  ReprojectionTable reprojection_;
  double max_reprojection_ = 0;  ///< [px]
  ReportSummary summary_;
  SnapshotResult pictures_;
  std::vector<std::vector<unsigned char>> picture_bytes_;  ///< The PNG files' bytes.
  std::ostringstream out_;
};

}  // namespace

ReportSummary writeReport(const fs::path& dataset, const fs::path& registration_dir,
                          const ReportOptions& options, const ProgressReporter& progress) {
  if (const std::string why = options.check(); !why.empty()) throw Error(why);
  progress.report("report: load", 0, 1);
  return ReportWriter(dataset, registration_dir, options).write(progress);
}

}  // namespace lookboth::report
