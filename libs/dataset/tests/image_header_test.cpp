#include "lookboth/dataset/image_header.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <fstream>
#include <opencv2/imgcodecs.hpp>

namespace lookboth {
namespace {

std::vector<std::uint8_t> encode(const std::string& ext, int width, int height,
                                 const std::vector<int>& params = {}) {
  cv::Mat image(height, width, CV_8UC1, cv::Scalar(90));
  std::vector<std::uint8_t> bytes;
  EXPECT_TRUE(cv::imencode(ext, image, bytes, params));
  return bytes;
}

TEST(ImageHeader, ReadsTheSizeOfEveryFormatWithoutDecoding) {
  for (const std::string ext : {".png", ".jpg", ".bmp", ".pgm"}) {
    const std::vector<std::uint8_t> bytes = encode(ext, 641, 359);
    const std::optional<ImageSize> size = encodedImageSize(bytes.data(), bytes.size());
    ASSERT_TRUE(size) << ext;
    EXPECT_EQ(size->width, 641) << ext;
    EXPECT_EQ(size->height, 359) << ext;
  }
  const std::vector<std::uint8_t> progressive =
      encode(".jpg", 320, 200, {cv::IMWRITE_JPEG_PROGRESSIVE, 1});
  const std::optional<ImageSize> size = encodedImageSize(progressive.data(), progressive.size());
  ASSERT_TRUE(size);
  EXPECT_EQ(size->width, 320);
  EXPECT_EQ(size->height, 200);
}

// The 30000x30000 PNG that would be decoded into 900 MB: its header is
// enough to refuse it (a 200-byte prefix here, as a corrupt file could be).
TEST(ImageHeader, AHugeDeclaredSizeIsReadFromTheHeaderAlone) {
  std::vector<std::uint8_t> png = encode(".png", 16, 16);
  const std::uint8_t huge[8] = {0, 0, 0x75, 0x30, 0, 0, 0x75, 0x30};  // 30000 x 30000
  std::copy(huge, huge + 8, png.begin() + 16);
  const std::optional<ImageSize> size = encodedImageSize(png.data(), 33);
  ASSERT_TRUE(size);
  EXPECT_EQ(size->width, 30000);
  EXPECT_EQ(size->height, 30000);
}

TEST(ImageHeader, TruncatedOrUnknownDataTellsNothing) {
  const std::vector<std::uint8_t> png = encode(".png", 16, 16);
  EXPECT_FALSE(encodedImageSize(png.data(), 20));
  const std::vector<std::uint8_t> jpg = encode(".jpg", 16, 16);
  EXPECT_FALSE(encodedImageSize(jpg.data(), 10));
  const std::uint8_t text[] = "hello, world";
  EXPECT_FALSE(encodedImageSize(text, sizeof text));
  EXPECT_FALSE(encodedImageSize(nullptr, 0));
  // A JPEG whose segment lengths run off the end.
  std::vector<std::uint8_t> bad = {0xFF, 0xD8, 0xFF, 0xE0, 0xFF, 0xFF, 0, 0};
  EXPECT_FALSE(encodedImageSize(bad.data(), bad.size()));
}

TEST(ImageHeader, ReadsAFilesHeader) {
  const std::filesystem::path file = std::filesystem::temp_directory_path() /
                                     ("lookboth_header_" + std::to_string(::getpid()) + ".jpg");
  const std::vector<std::uint8_t> jpg = encode(".jpg", 1920, 1080);
  std::ofstream(file, std::ios::binary)
      .write(reinterpret_cast<const char*>(jpg.data()), static_cast<std::streamsize>(jpg.size()));
  const std::optional<ImageSize> size = imageFileSize(file);
  std::filesystem::remove(file);
  ASSERT_TRUE(size);
  EXPECT_EQ(size->width, 1920);
  EXPECT_EQ(size->height, 1080);
  EXPECT_FALSE(imageFileSize(file));  // gone
}

}  // namespace
}  // namespace lookboth
