// Detects checkerboard corners in calibration photos and writes them as CSV,
// so that real calibrations can be checked in the tests without committing
// the photos (tests/data/cameras/real/*/SOURCE.md).
//
//   lookboth-board-corners [--board COLSxROWS] OUT.csv IMAGE...
//
// --board gives the inner-corner count; without it every size in kSizes is
// tried on every photo and the largest one found in at least half as many
// photos as the most often found size is kept (findChessboardCorners may also
// find sub-boards of a board, so the largest one is the whole board). The
// log on stderr names the sizes found in each photo, the detector, and the
// detections the saddle check (firstNonSaddle) rejected.
//
// CSV: a header line, then one line per corner:
//   image,cols,rows,index,u,v
// with index = row * cols + col in OpenCV's corner order and (u, v) in
// lookboth's pixel convention (0,0 the centre of the top-left pixel), which is
// OpenCV's. Photos without the board are listed on stderr and left out.
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

namespace {

/// Inner-corner counts of common printed checkerboards (cols x rows, cols >=
/// rows: OpenCV finds a board in either orientation with one of them).
const std::vector<cv::Size> kSizes = {{12, 9}, {11, 8}, {10, 7}, {9, 7}, {9, 6}, {8, 6},
                                      {8, 5},  {7, 6},  {7, 5},  {6, 5}, {6, 4}, {5, 4}};

struct Detection {
  std::string image;
  cv::Size size;
  std::vector<cv::Point2f> corners;
};

/// Mean intensity of a small square patch centred on `at` (sub-pixel).
double patchMean(const cv::Mat& gray, cv::Point2f at, int radius) {
  cv::Mat patch;
  cv::getRectSubPix(gray, cv::Size(2 * radius + 1, 2 * radius + 1), at, patch, CV_32F);
  return cv::mean(patch)[0];
}

/// Index of the first corner that is not a checkerboard saddle, or -1. At an
/// inner corner the four squares around it alternate dark and light: each
/// diagonal pair is one colour and the two pairs are well apart. A grid
/// shifted onto the board's white margin (as findChessboardCornersSB does on
/// some tilted boards) has a light square on both diagonals there.
int firstNonSaddle(const cv::Mat& gray, cv::Size size, const std::vector<cv::Point2f>& corners) {
  const auto at = [&](int col, int row) {
    return corners[static_cast<std::size_t>(row * size.width + col)];
  };
  for (int row = 0; row < size.height; ++row) {
    for (int col = 0; col < size.width; ++col) {
      // Half the distance to the neighbouring corners along the grid.
      const int c0 = std::max(col - 1, 0);
      const int c1 = std::min(col + 1, size.width - 1);
      const int r0 = std::max(row - 1, 0);
      const int r1 = std::min(row + 1, size.height - 1);
      const cv::Point2f u = (at(c1, row) - at(c0, row)) / (2.0f * static_cast<float>(c1 - c0));
      const cv::Point2f v = (at(col, r1) - at(col, r0)) / (2.0f * static_cast<float>(r1 - r0));
      // Halfway to the centres of the four squares: near a fisheye's rim
      // the squares shrink fast, and the full step would overshoot the
      // outermost ones.
      const cv::Point2f du = 0.5f * u;
      const cv::Point2f dv = 0.5f * v;
      const double side = std::min(cv::norm(du), cv::norm(dv));
      const int radius = std::max(1, static_cast<int>(0.3 * side));
      const cv::Point2f p = at(col, row);
      const double a0 = patchMean(gray, p + du + dv, radius);
      const double a1 = patchMean(gray, p - du - dv, radius);
      const double b0 = patchMean(gray, p + du - dv, radius);
      const double b1 = patchMean(gray, p - du + dv, radius);
      const double contrast = std::max({a0, a1, b0, b1}) - std::min({a0, a1, b0, b1});
      const double gap =
          std::max(std::min(a0, a1) - std::max(b0, b1), std::min(b0, b1) - std::max(a0, a1));
      if (!(gap > 0.3 * contrast)) return row * size.width + col;
    }
  }
  return -1;
}

/// OpenCV's classic detector first; findChessboardCornersSB where it fails
/// (it copes better with the strong distortion near a fisheye's rim). Both
/// are refined by cornerSubPix, so every corner gets the same refinement,
/// and both must pass the saddle check. `log` says what happened.
bool detect(const cv::Mat& gray, cv::Size size, std::vector<cv::Point2f>* corners,
            std::string* log) {
  const std::string name = std::to_string(size.width) + "x" + std::to_string(size.height);
  log->clear();
  for (const bool sb : {false, true}) {
    corners->clear();  // what the classic detector left is no starting point
    const bool found =
        sb ? cv::findChessboardCornersSB(gray, size, *corners,
                                         cv::CALIB_CB_EXHAUSTIVE | cv::CALIB_CB_ACCURACY)
           : cv::findChessboardCorners(gray, size, *corners,
                                       cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE);
    if (!found) continue;
    // The search window scales with the image: at 1440 px the squares are
    // tens of pixels wide, at 640 px around ten.
    const int half = std::max(3, std::min(gray.cols, gray.rows) / 120);
    cv::cornerSubPix(gray, *corners, cv::Size(half, half), cv::Size(-1, -1),
                     cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 100, 1e-3));
    const int bad = firstNonSaddle(gray, size, *corners);
    const std::string detector = sb ? "sb" : "classic";
    if (bad < 0) {
      *log += " " + name + " (" + detector + ")";
      return true;
    }
    *log += " " + name + " (" + detector + ": rejected, corner " + std::to_string(bad) +
            " is not a saddle)";
  }
  return false;
}

int usage() {
  std::cerr << "usage: lookboth-board-corners [--board COLSxROWS] OUT.csv IMAGE...\n";
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<cv::Size> sizes = kSizes;
  std::vector<std::string> args;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--board" && i + 1 < argc) {
      int cols = 0;
      int rows = 0;
      if (std::sscanf(argv[++i], "%dx%d", &cols, &rows) != 2 || cols < 2 || rows < 2) {
        return usage();
      }
      sizes = {cv::Size(cols, rows)};
    } else {
      args.push_back(arg);
    }
  }
  if (args.size() < 2) return usage();

  std::vector<Detection> detections;
  std::map<int, int> found_per_size;  // index into sizes -> photos
  for (std::size_t i = 1; i < args.size(); ++i) {
    const cv::Mat gray = cv::imread(args[i], cv::IMREAD_GRAYSCALE);
    if (gray.empty()) {
      std::cerr << args[i] << ": cannot read\n";
      return 1;
    }
    std::string found;  // what each size gave, for the log
    for (std::size_t s = 0; s < sizes.size(); ++s) {
      Detection d{std::filesystem::path(args[i]).filename().string(), sizes[s], {}};
      std::string log;
      if (detect(gray, sizes[s], &d.corners, &log)) {
        ++found_per_size[static_cast<int>(s)];
        detections.push_back(std::move(d));
      }
      found += log;
    }
    std::cerr << args[i] << ":" << (found.empty() ? " no board" : found) << "\n";
  }
  if (found_per_size.empty()) {
    std::cerr << "no board found in any photo\n";
    return 1;
  }
  // The largest size found in at least half the photos: a sub-board is found
  // wherever the whole board is, a size found once may be a chance fit.
  int most = 0;
  for (const auto& [s, count] : found_per_size) most = std::max(most, count);
  int best = -1;
  for (const auto& [s, count] : found_per_size) {
    if (2 * count < most) continue;
    if (best < 0 ||
        sizes[static_cast<std::size_t>(s)].area() > sizes[static_cast<std::size_t>(best)].area()) {
      best = s;
    }
  }
  const cv::Size board = sizes[static_cast<std::size_t>(best)];
  std::cerr << "board " << board.width << "x" << board.height << " inner corners, found in "
            << found_per_size[best] << " of " << args.size() - 1 << " photos\n";

  std::ofstream out(args[0]);
  out << "image,cols,rows,index,u,v\n";
  char line[256];
  for (std::size_t i = 1; i < args.size(); ++i) {
    const std::string name = std::filesystem::path(args[i]).filename().string();
    bool found = false;
    for (const Detection& d : detections) {
      if (d.image != name || d.size != board) continue;
      found = true;
      for (std::size_t k = 0; k < d.corners.size(); ++k) {
        std::snprintf(line, sizeof(line), "%s,%d,%d,%zu,%.3f,%.3f\n", name.c_str(), board.width,
                      board.height, k, d.corners[k].x, d.corners[k].y);
        out << line;
      }
    }
    if (!found) std::cerr << name << ": no " << board.width << "x" << board.height << " board\n";
  }
  if (!out) {
    std::cerr << args[0] << ": cannot write\n";
    return 1;
  }
  return 0;
}
