// Private to libs/dataset: the concrete readers and writers behind the
// factories of dataset_io.h.
#pragma once

#include "lookboth/dataset/dataset_io.h"

namespace lookboth::internal {

std::unique_ptr<DatasetReader> openRawlogReader(const std::filesystem::path& rawlog,
                                                const DatasetReadOptions& options);
std::unique_ptr<DatasetReader> openFolderReader(const std::filesystem::path& folder,
                                                const DatasetReadOptions& options);

std::unique_ptr<DatasetWriter> createRawlogWriter(const std::filesystem::path& rawlog,
                                                  const Manifest& manifest,
                                                  const DatasetWriteOptions& options);
std::unique_ptr<DatasetWriter> createFolderWriter(const std::filesystem::path& folder,
                                                  const Manifest& manifest,
                                                  const DatasetWriteOptions& options);

/// A fresh temporary path beside `destination` (same directory, so a rename
/// is atomic): "<dir>/.<name>.tmp-<pid>-<n>".
std::filesystem::path temporarySibling(const std::filesystem::path& destination);

/// Moves a finished temporary file or folder onto `destination`, replacing an
/// existing one only when `overwrite` (the old one is removed after the new
/// one is in place). Throws lookboth::Error naming the destination on failure.
void moveIntoPlace(const std::filesystem::path& temporary, const std::filesystem::path& destination,
                   bool overwrite);

/// Throws lookboth::Error when `destination` exists and !overwrite, or when
/// its parent directory does not exist.
void checkOutputPath(const std::filesystem::path& destination, bool overwrite);

/// Puts an existing image file at `target`: a hard link when `link` (a copy
/// when linking fails, e.g. across file systems), else a copy. Throws
/// lookboth::Error naming the source and `subject` (the camera) on failure.
void placeImageFile(const std::filesystem::path& source, const std::filesystem::path& target,
                    bool link, const std::string& subject);

}  // namespace lookboth::internal
