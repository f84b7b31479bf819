// Hidden temporaries that a killed run leaves behind. Every output is first
// written under a hidden name that carries the writer's process id
// (".<name>.tmp-<pid>-<n>", a dataset's ".<stem>.new-<pid>-<n>.rawlog" with
// its ".yaml" and "_Images", register's scratch dataset
// ".<out>-dataset-tmp-<pid>", ".lookboth-report-<pid>-<n>"); a SIGKILL, a power cut or a crash
// leaves it there. The next run that writes into the same folder removes those whose process is
// gone, so they never pile up.
#pragma once

#include <filesystem>
#include <string>

namespace lookboth {

/// The process id in a temporary name of the forms above; 0 when `name` is
/// not one (ordinary files, and ".<name>.old-<pid>-<n>" copies, which may be
/// the only complete copy of a dataset after a crash in the middle of a swap
/// and are never removed automatically).
long temporaryOwner(const std::string& name);

/// Removes the temporaries in `dir` whose owner process no longer exists and
/// that were not modified in the last `min_age_s` seconds (a writer on
/// another machine sharing the folder keeps touching its own). Each folder
/// is scanned at most once per process. Returns how many were removed;
/// never throws.
int removeStaleTemporaries(const std::filesystem::path& dir, double min_age_s = 60);

}  // namespace lookboth
