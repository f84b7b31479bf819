// Adding records to an existing dataset (detections, a VO trajectory...) and
// joining datasets that share their frames (the shards of `lookboth detect
// --cameras`).
//
// The input is never written to. A new dataset is written under a temporary
// name beside the output (images hard-linked, not copied, when they can be)
// and moved into place only when complete; when the output is the input, the
// swap moves the old dataset aside, the new one in, then removes the old one,
// so an interruption at any point leaves one complete dataset (either the
// old one under its name, or - after a crash in the middle of the swap -
// under a hidden name ".<stem>.old-*" beside it).
#pragma once

#include <filesystem>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "lookboth/core/progress.h"
#include "lookboth/dataset/dataset_io.h"

namespace lookboth {

struct AugmentOptions {
  std::filesystem::path input;  ///< A dataset (.rawlog or folder).
  /// Where the result goes; empty or equal to `input`: replace the input.
  /// Its layout is the input's.
  std::filesystem::path output;
  bool overwrite = false;  ///< Replace an existing `output` (other than the input).
  /// Existing records for which this returns true are left out (e.g. the
  /// previous detections of a kind and camera being re-detected). May be empty.
  std::function<bool(const Record&)> drop;
  /// The manifest of the result (e.g. with a TrajectoryInfo added); nullopt: the input's.
  std::optional<Manifest> manifest;
  /// Hard-link image files rather than copying them (a copy when linking fails).
  bool link_images = true;
  /// Called for every input issue as it is found.
  std::function<void(const DatasetIssue&)> on_issue;
  /// Empty when valid; else a message naming the option.
  std::string check() const;
};

struct AugmentSummary {
  std::int64_t copied = 0;   ///< Records of the input kept.
  std::int64_t dropped = 0;  ///< Records of the input left out by `drop`.
  std::int64_t added = 0;    ///< New records written.
  std::filesystem::path output;
  std::vector<DatasetIssue> issues;  ///< Warnings found in the input.
};

/// Copies the input's records and inserts `added` in time order (a new
/// record goes after the input's records with the same time; `added` need
/// not be sorted, its order is kept among equal times). Throws
/// lookboth::Error on bad input or options (nothing is written then),
/// StopRequested when stopped (the input is untouched, no output appears).
AugmentSummary augmentDataset(const AugmentOptions& options, std::vector<Record> added,
                              const ProgressReporter& progress);

/// A key that identifies a record independently of its content: kind,
/// label, time (and marker id for markers). Two records with the same key
/// are the same measurement (possibly estimated twice).
std::string recordKey(const Record& record);

struct MergeOptions {
  std::vector<std::filesystem::path> inputs;  ///< Datasets of one recording (>= 2).
  std::filesystem::path output;               ///< Layout from its name (.rawlog or folder).
  bool overwrite = false;
  bool link_images = true;
  std::function<void(const DatasetIssue&)> on_issue;
  std::string check() const;
};

struct MergeSummary {
  std::map<std::string, std::int64_t> records;  ///< Written, by kind.
  std::int64_t duplicates = 0;                  ///< Records left out as already present.
  std::vector<DatasetIssue> issues;
};

/// Joins datasets recorded together (e.g. the outputs of `lookboth detect
/// --cameras a` and `--cameras b` run on copies of one dataset, or each edge
/// node's `detect --detections-only` of its own camera): records of all
/// inputs in time order (a k-way merge; inputs are expected in time order),
/// a record whose recordKey() was already written (a frame every shard
/// copied) written once, from the first input that holds it. The manifest is
/// the first input's with the cameras, trajectories and ground truth of the
/// others added; a camera two inputs list must have the same role and
/// calibration, and every input the same marker (else lookboth::Error naming
/// the input and the camera or field).
MergeSummary mergeDatasets(const MergeOptions& options, const ProgressReporter& progress);

}  // namespace lookboth
