// Private to libs/dataset: what the video reader and writer share of FFmpeg.
#pragma once

#include <filesystem>
#include <string>

#include "lookboth/core/error.h"

namespace lookboth::internal {

/// FFmpeg's text for an error code ("Invalid data found when processing input").
std::string averror(int code);

/// FFmpeg prints its own diagnostics on stderr; ours name the file instead.
void quietFfmpeg();

/// An error about a video file, naming it.
Error videoError(const std::filesystem::path& file, const std::string& message);

}  // namespace lookboth::internal
