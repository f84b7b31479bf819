// The size of an encoded image read from its header, without decoding it:
// a frame whose size does not match its camera's calibration is skipped
// before a 30000x30000 PNG is decoded into gigabytes.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <optional>

namespace lookboth {

struct ImageSize {
  int width = 0;
  int height = 0;
};

/// The width and height declared by a PNG, JPEG (baseline or progressive),
/// BMP or binary PGM/PPM header; nullopt for other formats or a header too
/// short or malformed to tell (the decoder then decides).
std::optional<ImageSize> encodedImageSize(const std::uint8_t* data, std::size_t size);

/// The same for an image file: reads only as much of the file as the header
/// needs (a JPEG's segments are skipped by their lengths).
std::optional<ImageSize> imageFileSize(const std::filesystem::path& file);

}  // namespace lookboth
