#include "lookboth/dataset/image_header.h"

#include <cstring>
#include <fstream>
#include <vector>

namespace lookboth {

namespace {

std::uint32_t bigEndian32(const std::uint8_t* p) {
  return (std::uint32_t(p[0]) << 24) | (std::uint32_t(p[1]) << 16) | (std::uint32_t(p[2]) << 8) |
         std::uint32_t(p[3]);
}
std::uint32_t bigEndian16(const std::uint8_t* p) { return (std::uint32_t(p[0]) << 8) | p[1]; }
std::int32_t littleEndian32(const std::uint8_t* p) {
  return static_cast<std::int32_t>(std::uint32_t(p[0]) | (std::uint32_t(p[1]) << 8) |
                                   (std::uint32_t(p[2]) << 16) | (std::uint32_t(p[3]) << 24));
}

std::optional<ImageSize> checked(long long width, long long height) {
  if (width <= 0 || height <= 0 || width > (1LL << 30) || height > (1LL << 30)) return std::nullopt;
  return ImageSize{static_cast<int>(width), static_cast<int>(height)};
}

std::optional<ImageSize> pngSize(const std::uint8_t* d, std::size_t n) {
  // Signature (8), IHDR length (4) and type (4), then width and height.
  if (n < 24 || std::memcmp(d + 12, "IHDR", 4) != 0) return std::nullopt;
  return checked(bigEndian32(d + 16), bigEndian32(d + 20));
}

std::optional<ImageSize> jpegSize(const std::uint8_t* d, std::size_t n) {
  std::size_t i = 2;  // after SOI
  while (i + 4 <= n) {
    if (d[i] != 0xFF) return std::nullopt;
    const std::uint8_t marker = d[i + 1];
    if (marker == 0xFF) {  // fill byte
      ++i;
      continue;
    }
    if (marker == 0xD8 || (marker >= 0xD0 && marker <= 0xD7) || marker == 0x01) {
      i += 2;  // markers without a length
      continue;
    }
    const std::size_t length = bigEndian16(d + i + 2);
    if (length < 2) return std::nullopt;
    // Start-of-frame markers (baseline, progressive, lossless...), not DHT/JPG/DAC.
    const bool sof =
        marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 && marker != 0xC8 && marker != 0xCC;
    if (sof) {
      if (i + 9 > n) return std::nullopt;
      return checked(bigEndian16(d + i + 7), bigEndian16(d + i + 5));
    }
    if (marker == 0xDA || marker == 0xD9) return std::nullopt;  // scan data before any frame
    i += 2 + length;
  }
  return std::nullopt;
}

std::optional<ImageSize> bmpSize(const std::uint8_t* d, std::size_t n) {
  if (n < 26) return std::nullopt;
  const long long height = littleEndian32(d + 22);
  return checked(littleEndian32(d + 18), height < 0 ? -height : height);
}

std::optional<ImageSize> pnmSize(const std::uint8_t* d, std::size_t n) {
  // "P5"/"P6", whitespace and comments, width, height.
  long long values[2] = {0, 0};
  std::size_t i = 2;
  for (long long& value : values) {
    for (;;) {
      while (i < n && (d[i] == ' ' || d[i] == '\t' || d[i] == '\r' || d[i] == '\n')) ++i;
      if (i < n && d[i] == '#') {
        while (i < n && d[i] != '\n') ++i;
        continue;
      }
      break;
    }
    std::size_t digits = 0;
    while (i < n && d[i] >= '0' && d[i] <= '9' && digits < 10) {
      value = value * 10 + (d[i++] - '0');
      ++digits;
    }
    if (digits == 0) return std::nullopt;
  }
  return checked(values[0], values[1]);
}

}  // namespace

std::optional<ImageSize> encodedImageSize(const std::uint8_t* data, std::size_t size) {
  if (!data || size < 4) return std::nullopt;
  static const std::uint8_t kPng[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
  if (size >= 8 && std::memcmp(data, kPng, 8) == 0) return pngSize(data, size);
  if (data[0] == 0xFF && data[1] == 0xD8) return jpegSize(data, size);
  if (data[0] == 'B' && data[1] == 'M') return bmpSize(data, size);
  if (data[0] == 'P' && (data[1] == '5' || data[1] == '6')) return pnmSize(data, size);
  return std::nullopt;
}

std::optional<ImageSize> imageFileSize(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) return std::nullopt;
  // Enough for every header above, with a JPEG's EXIF and ICC segments.
  std::vector<std::uint8_t> head(256 * 1024);
  in.read(reinterpret_cast<char*>(head.data()), static_cast<std::streamsize>(head.size()));
  head.resize(static_cast<std::size_t>(in.gcount()));
  return encodedImageSize(head.data(), head.size());
}

}  // namespace lookboth
