// `lookboth detect`: the marker in the environment cameras' frames, the
// housings (blobs) in the fisheye's frames, added to the dataset; optionally
// scored against a simulated dataset's ground truth.
#include <cmath>
#include <cstdio>
#include <iostream>
#include <limits>

#include "commands.h"
#include "lookboth/core/error.h"
#include "lookboth/core/progress.h"
#include "lookboth/core/text.h"
#include "lookboth/detect/detect_dataset.h"
#include "lookboth/detect/detection_evaluation.h"
#include "signals.h"

namespace lookboth::app {
namespace {

struct DetectArgs {
  std::string dataset;
  std::string out;
  std::string config;
  std::vector<std::string> cameras;
  int threads = 0;
  bool overwrite = false;
  bool no_markers = false;
  bool no_blobs = false;
  bool evaluate = false;
  bool verbose = false;
  bool dry_run = false;
  bool detections_only = false;
};

void printEvaluation(const DetectOptions& options, const DetectSummary& summary,
                     const std::vector<Record>& records) {
  const GroundTruthView truth = loadGroundTruth(options.dataset);
  std::vector<MarkerObservation> markers;
  std::vector<BlobObservation> blobs;
  for (const Record& r : records) {
    if (const auto* m = std::get_if<MarkerObservation>(&r)) markers.push_back(*m);
    if (const auto* b = std::get_if<BlobObservation>(&r)) blobs.push_back(*b);
  }
  if (!summary.searched.empty()) {
    const MarkerEvaluation e =
        evaluateMarkers(truth, markers, summary.searched, {0.0, 2.5, 3.0, 3.5, 4.0, 5.0, 100.0});
    std::printf(
        "markers vs ground truth: recall %d/%d (%.1f %%), false positives %d, "
        "mean NEES %.2f (6 expected)\n",
        e.detected_frames, e.visible_frames, 100 * e.recall(), e.false_positives, e.mean_nees);
    if (e.passes > 0) {
      std::printf(
          "  per pass (%d passes, %.1f detections each): mean NEES of the pass's weighted mean "
          "error as a camera pose error %.2f (6 expected when the errors are independent);\n"
          "  the share of a detection's error common to its pass (pass_error_share): %.3f\n",
          e.passes, e.mean_pass_detections, e.mean_pass_nees, e.pass_error_share);
    }
    for (const std::string& note : e.false_positive_notes)
      std::printf("  false positive: %s\n", note.c_str());
    std::printf("  %-12s %6s %12s %12s %14s %12s %10s\n", "distance m", "n", "pos med mm",
                "pos p90 mm", "along med mm", "in-plane deg", "tilt deg");
    for (size_t b = 0; b < e.bands.size(); ++b) {
      const MarkerErrorBand& band = e.bands[b];
      if (band.count == 0) continue;
      char range[32];
      if (b + 1 == e.bands.size()) {
        std::snprintf(range, sizeof range, "all");
      } else {
        std::snprintf(range, sizeof range, "%.1f-%.1f", band.min_distance_m, band.max_distance_m);
      }
      std::printf("  %-12s %6d %12.2f %12.2f %+14.2f %12.3f %10.3f\n", range, band.count,
                  band.median_position_mm, band.p90_position_mm, band.median_along_sight_mm,
                  band.median_in_plane_deg, band.median_tilt_deg);
    }
  }
  if (!blobs.empty()) {
    // Housings by distance from the fisheye [m]: the ceiling right above, the
    // ranges a housing's blob shrinks through, and the far ones near the
    // fisheye's horizon that other ceiling elements hide most often.
    constexpr double kFar = std::numeric_limits<double>::infinity();
    const BlobEvaluation e = evaluateBlobs(truth, blobs, 6.0, {0.0, 3.0, 4.0, 6.0, kFar});
    std::printf(
        "blobs vs ground truth: %d frames, recall %d/%d (%.1f %%; %s), false positives %.2f "
        "per frame, precision %.1f %%, centre error median %.2f px, p90 %.2f px\n",
        e.frames, e.matched, e.expected, 100 * e.recall(),
        e.knows_hidden ? "of the housings the fisheye sees"
                       : "the dataset names no hidden housing: any hidden one counts as missed",
        e.falsePositivesPerFrame(), 100 * e.precision(), e.median_error_px, e.p90_error_px);
    if (e.knows_hidden) {
      std::printf(
          "  %d more hidden from the fisheye by the world (%d of them with a blob); over every "
          "housing in the image, as without the spans, %d/%d (%.1f %%)\n",
          e.hidden, e.hidden_matched, e.matched + e.hidden_matched, e.expected + e.hidden,
          100 * e.recallOfAllInImage());
    }
    std::printf("  %-12s %9s %9s %9s %15s\n", "distance m", "expected", "matched", "recall %",
                "centre med px");
    for (const BlobBand& band : e.bands) {
      if (band.expected == 0) continue;
      char range[32];
      if (std::isinf(band.max_distance_m)) {
        std::snprintf(range, sizeof range, ">=%.1f", band.min_distance_m);
      } else {
        std::snprintf(range, sizeof range, "%.1f-%.1f", band.min_distance_m, band.max_distance_m);
      }
      std::printf("  %-12s %9d %9d %9.1f %15.2f\n", range, band.expected, band.matched,
                  100 * band.recall(), band.median_error_px);
    }
    if (e.passes > 0) {
      std::printf(
          "  per pass (%d passes): mean NEES of the pass's mean error %.2f (2 expected when the "
          "errors are independent);\n  the share of a blob's error common to its pass %.3f, "
          "%.3f px per coordinate (blob_pass_error_share = its square over blob_sigma_px's)\n",
          e.passes, e.mean_pass_nees, e.pass_error_share, e.shared_error_px);
    }
  }
}

/// --verbose: what became of the fisheye's blob candidates.
void printBlobCandidates(const BlobDetectorStats& b) {
  std::cout << "    " << b.candidates << " blob candidates: " << b.too_small << " smaller and "
            << b.too_big << " larger than a housing there, " << b.low_contrast
            << " below min_contrast, " << b.not_dark << " not dark enough (max_darkness_ratio)\n";
}

int runDetect(const DetectArgs& args) {
  DetectOptions options;
  options.dataset = args.dataset;
  options.out = args.out;
  options.overwrite = args.overwrite;
  options.cameras = args.cameras;
  options.threads = args.threads;
  options.markers = !args.no_markers;
  options.blobs = !args.no_blobs;
  options.detections_only = args.detections_only;
  options.config = detectConfigFor(
      args.config.empty() ? std::nullopt : std::optional<std::filesystem::path>(args.config));
  options.on_issue = printDatasetIssue;
  if (const std::string why = options.check(); !why.empty()) throw Error(why);

  const ProgressReporter progress(makeConsoleProgress());
  const StopOnSignal stop_on_signal(progress);
  try {
    DetectSummary summary;
    std::vector<Record> records;
    if (args.dry_run || args.evaluate) {
      records = runDetection(options, progress, &summary);
    }
    if (!args.dry_run) {
      if (args.evaluate) {
        // Write what was evaluated (no second detection run).
        summary.written = writeDetections(options, records, summary, progress);
      } else {
        summary = detectDataset(options, progress);
      }
    }
    std::int64_t frames = 0, markers = 0, blob_records = 0;
    for (const CameraDetectSummary& c : summary.cameras) {
      frames += c.frames;
      (c.fisheye ? blob_records : markers) += c.detections;
      std::cout << "  " << c.camera << ": " << c.frames << " frames";
      if (!c.fisheye && c.examined < c.frames) {
        std::cout << " (" << c.examined << " examined"
                  << (c.coarse_key_frames ? ", coarsely at its key frames" : "");
        if (c.unchanged) std::cout << "; " << c.unchanged << " unchanged, not searched";
        if (c.previews) std::cout << "; " << c.previews << " key frames searched as previews";
        std::cout << ")";
      }
      if (c.fisheye) {
        std::cout << ", " << c.blobs << " blobs";
      } else {
        std::cout << ", " << c.detections << " markers";
        if (c.ambiguous) {
          std::cout << " (" << c.ambiguous << " ambiguous from one frame, " << c.unresolved
                    << " unresolved)";
        }
        if (c.fixed_markers) std::cout << ", " << c.fixed_markers << " of fixed markers";
      }
      if (c.rejected) std::cout << ", " << c.rejected << " rejected (inconsistent with the track)";
      if (c.skipped) std::cout << ", " << c.skipped << " skipped (undecodable)";
      const MarkerDetectorStats& m = c.marker_candidates;
      std::int64_t dropped = 0;
      for (const auto& [why, n] : m.rejected) dropped += n;
      if (m.fallbacks) std::cout << ", " << m.fallbacks << " with OpenCV's corners";
      if (dropped) std::cout << ", " << dropped << " candidates dropped";
      std::cout << "\n";
      if (args.verbose) {
        for (const auto& [why, n] : m.fallback_reasons)
          std::cout << "    " << n << " with OpenCV's corners (cornerSubPix): " << why << "\n";
        for (const auto& [why, n] : m.rejected)
          std::cout << "    " << n << " candidates dropped: " << why << "\n";
        if (c.fisheye) printBlobCandidates(c.blob_candidates);
      }
    }
    std::cout << (args.dry_run ? "detected (not written): " : "wrote ")
              << (args.dry_run ? std::string() : summary.written.output.string() + ": ") << markers
              << " marker observations, " << blob_records << " blob records from " << frames
              << " frames in " << formatFixed(summary.detect_seconds, 1) << " s\n";
    if (args.evaluate) printEvaluation(options, summary, records);
    return 0;
  } catch (const StopRequested&) {
    std::cerr << "lookboth: stopped; " << args.dataset << " is unchanged\n";
    return 130;
  }
}

}  // namespace

void registerDetectCommand(CLI::App& app, const std::function<void(CommandBody)>& set_body) {
  auto args = std::make_shared<DetectArgs>();
  CLI::App* cmd = app.add_subcommand(
      "detect",
      "Detect the robot's marker in the environment cameras' frames and the cameras' housings "
      "(blobs) in the fisheye's frames; add them to the dataset");
  cmd->add_option("dataset", args->dataset, "The dataset (x.rawlog or a folder)")->required();
  cmd->add_option("--out", args->out,
                  "Write the result here instead of replacing the dataset (same layout)");
  cmd->add_flag("--overwrite", args->overwrite, "Replace an existing --out");
  cmd->add_option("--cameras", args->cameras,
                  "Only these cameras (labels, comma-separated; the fisheye's label for blobs)")
      ->delimiter(',');
  cmd->add_option("--threads", args->threads, "Worker threads (0 = one per core)")
      ->check(CLI::Range(0, 256));
  cmd->add_option("--config", args->config,
                  "Configuration YAML (its detect: section); default: "
                  "share/lookboth/config/default.yaml");
  cmd->add_flag("--no-markers", args->no_markers, "Skip the environment cameras");
  cmd->add_flag("--no-blobs", args->no_blobs, "Skip the fisheye");
  cmd->add_flag("--verbose", args->verbose,
                "Per camera, why the edge fit fell back to OpenCV's corners and why candidates "
                "were dropped, with counts");
  cmd->add_flag("--evaluate", args->evaluate,
                "Score the detections against the dataset's ground truth (simulated datasets)");
  cmd->add_flag("--dry-run", args->dry_run, "Detect (and evaluate) without writing anything");
  cmd->add_flag("--detections-only", args->detections_only,
                "Write only the detections to --out (no frames, no trajectories): an edge "
                "node's result for `lookboth convert --merge`");
  cmd->callback([args, set_body] { set_body([args] { return runDetect(*args); }); });
}

}  // namespace lookboth::app
