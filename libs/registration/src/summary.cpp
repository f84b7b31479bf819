// The registration as text for a terminal: the result, one table row per
// camera, then what to act on (registration.h, registrationSummary).
#include <iomanip>
#include <sstream>

#include "lookboth/core/text.h"
#include "lookboth/registration/registration.h"

namespace lookboth {

namespace {

/// "+250.7 +- 2.3" [ms], "-" when joint did not estimate it.
std::string clockColumn(const CameraRegistration& c) {
  if (!c.clock_offset) return "-";
  const double ms = static_cast<double>(c.clock_offset->offset_ns) * 1e-6;
  std::string text = (ms >= 0 ? "+" : "") + formatFixed(ms, 1);
  if (c.clock_offset->sigma_ms > 0) text += " +- " + formatFixed(c.clock_offset->sigma_ms, 1);
  return text;
}

/// The table's last column: why a camera is not registered, or a pointer
/// to its warnings below.
std::string notesColumn(const CameraRegistration& c) {
  std::string text = c.reason;
  if (!c.warnings.empty()) {
    text += (text.empty() ? "" : "; ") + std::to_string(c.warnings.size()) +
            (c.warnings.size() == 1 ? " warning" : " warnings") + " below";
  }
  return text;
}

/// "  - text" wrapped, later lines aligned under the text.
std::string bullet(const std::string& text) {
  std::string out = wrapSentences(text, "    ");
  return out.empty() ? "  -" : out.replace(0, 4, "  - ");
}

void writeCameraTable(std::ostream& out, const Registration& r) {
  out << std::left << std::setw(10) << "camera" << std::setw(14) << "status" << std::setw(12)
      << "used/total" << std::setw(17) << "clock_ms" << std::setw(11) << "pos_rms_m"
      << std::setw(12) << "rot_rms_deg" << std::setw(26) << "reproj_px before > after"
      << "notes\n";
  for (const CameraRegistration& c : r.cameras) {
    out << std::left << std::setw(10) << c.label << std::setw(14) << cameraStatusName(c.status)
        << std::setw(12)
        << (std::to_string(c.detections.used) + "/" + std::to_string(c.detections.total))
        << std::setw(17) << clockColumn(c) << std::setw(11)
        << (c.residuals ? formatFixed(c.residuals->position_rms_m, 4) : "-") << std::setw(12)
        << (c.residuals ? formatFixed(c.residuals->rotation_rms_deg, 2) : "-") << std::setw(26)
        << (c.reprojection ? formatFixed(c.reprojection->rms_px_before, 2) + " > " +
                                 formatFixed(c.reprojection->rms_px_after, 2)
                           : "-")
        << notesColumn(c) << "\n";
  }
}

}  // namespace

std::string registrationSummary(const Registration& r, bool verbose) {
  std::ostringstream out;
  int registered = 0, suspect = 0, unregistered = 0;
  for (const CameraRegistration& c : r.cameras) {
    if (c.status == CameraStatus::kRegistered) ++registered;
    if (c.status == CameraStatus::kSuspect) ++suspect;
    if (c.status == CameraStatus::kUnregistered) ++unregistered;
  }
  out << "registered " << registered + suspect << " of " << r.cameras.size() << " cameras ("
      << suspect << " suspect, " << unregistered << " unregistered) with the "
      << trajectoryModeName(r.trajectory_mode) << " trajectory '" << r.trajectory_label << "'\n";
  out << "scale " << formatFixed(r.scale, 6);
  if (r.scale_sigma > 0) out << " +- " << formatFixed(r.scale_sigma, 6);
  const Eigen::Vector3d t = r.fisheye_from_marker.translation;
  out << "; fisheye_from_marker t = [" << formatFixed(t.x(), 4) << ", " << formatFixed(t.y(), 4)
      << ", " << formatFixed(t.z(), 4) << "] m\n";
  if (r.observability.aligned_position_rmse_m) {
    out << "camera positions: RMS error predicted after a rigid alignment to any reference "
        << formatFixed(*r.observability.aligned_position_rmse_m * 1000, 2) << " mm\n";
  }
  out << "detections: " << r.statistics.detections_total << " total, "
      << r.statistics.detections_associated << " associated, "
      << r.statistics.dropped_outside_trajectory << " outside the trajectory, "
      << r.statistics.dropped_gap << " in gaps\n";
  writeCameraTable(out, r);
  if (r.reprojection) {
    out << "reprojection: " << r.reprojection->blobs << " blobs, RMS "
        << formatFixed(r.reprojection->rms_px_before, 2) << " px before, "
        << formatFixed(r.reprojection->rms_px_after, 2) << " px after "
        << r.reprojection->after_stage << "\n";
  }
  const std::vector<std::string> notes = r.labelledNotes();
  if (verbose) {
    out << "observability:\n" << wrapSentences(r.observability.message, "  ") << "\n";
    if (!notes.empty()) out << "notes:\n";
    for (const std::string& n : notes) out << bullet(n) << "\n";
  }
  const std::vector<std::string> warnings = r.labelledWarnings();
  out << "warnings: " << (warnings.empty() ? std::string("none") : std::to_string(warnings.size()));
  if (!verbose && !notes.empty()) {
    out << "; notes: " << notes.size() << " (nothing to act on; --verbose, or registration.yaml)";
  }
  out << "\n";
  for (const std::string& w : warnings) out << bullet("warning: " + w) << "\n";
  out << "time:";
  for (const auto& [stage, seconds] : r.statistics.seconds_per_stage) {
    out << " " << stage << " " << formatFixed(seconds, 2) << " s";
  }
  out << "\n";
  return out.str();
}

}  // namespace lookboth
