#include "lookboth/report/draw.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "lookboth/core/text.h"

namespace lookboth::report {
namespace {

const cv::Scalar kWhite(255, 255, 255);
const cv::Scalar kBlack(0, 0, 0);
const cv::Scalar kGrid(225, 225, 225);
constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;

cv::Mat toBgr(const cv::Mat& image, cv::Size size) {
  cv::Mat bgr;
  if (image.empty()) {
    bgr = cv::Mat(size, CV_8UC3, cv::Scalar(40, 40, 40));
  } else if (image.channels() == 1) {
    cv::cvtColor(image, bgr, cv::COLOR_GRAY2BGR);
  } else if (image.channels() == 4) {
    cv::cvtColor(image, bgr, cv::COLOR_BGRA2BGR);
  } else {
    bgr = image.clone();
  }
  return bgr;
}

/// Resizes to `out_size`; returns the scale factors (x, y) from input pixels
/// (centre convention) to output pixels.
cv::Mat resizeTo(const cv::Mat& bgr, cv::Size out_size) {
  if (bgr.size() == out_size) return bgr;
  cv::Mat resized;
  cv::resize(bgr, resized, out_size, 0, 0, cv::INTER_AREA);
  return resized;
}

/// Input pixel (centre convention) -> output pixel (centre convention).
struct PixelScale {
  double sx = 1, sy = 1;
  cv::Point2d operator()(const Eigen::Vector2d& p) const {
    return {(p.x() + 0.5) * sx - 0.5, (p.y() + 0.5) * sy - 0.5};
  }
};

cv::Point rounded(const cv::Point2d& p) {
  return {static_cast<int>(std::lround(p.x)), static_cast<int>(std::lround(p.y))};
}

/// White text with a dark outline: readable on any background.
void outlinedText(cv::Mat& image, const std::string& text, cv::Point at, double scale,
                  const cv::Scalar& colour = kWhite, int thickness = 1) {
  cv::putText(image, text, at, kFont, scale, kBlack, thickness + 2, cv::LINE_AA);
  cv::putText(image, text, at, kFont, scale, colour, thickness, cv::LINE_AA);
}

double fontScaleFor(cv::Size size) { return std::clamp(size.width / 1900.0, 0.33, 0.8); }

void drawCross(cv::Mat& image, cv::Point at, int half, const cv::Scalar& colour, int thickness) {
  cv::line(image, at + cv::Point(-half, -half), at + cv::Point(half, half), colour, thickness,
           cv::LINE_8);
  cv::line(image, at + cv::Point(-half, half), at + cv::Point(half, -half), colour, thickness,
           cv::LINE_8);
}

int legendLineHeight(double font_scale) {
  int baseline = 0;
  return static_cast<int>(cv::getTextSize("Ag", kFont, font_scale, 1, &baseline).height * 1.9) + 2;
}
}  // namespace

cv::Size measureLegend(const std::vector<std::pair<std::string, cv::Scalar>>& entries,
                       const std::vector<std::string>& notes, double font_scale) {
  int baseline = 0;
  const int line_height = legendLineHeight(font_scale);
  int width = 0;
  for (const auto& [text, colour] : entries) {
    width = std::max(width, cv::getTextSize(text, kFont, font_scale, 1, &baseline).width + 30);
  }
  for (const std::string& note : notes) {
    width = std::max(width, cv::getTextSize(note, kFont, font_scale, 1, &baseline).width);
  }
  const int rows = static_cast<int>(entries.size() + notes.size());
  return cv::Size(width + 16, rows * line_height + 10);
}

int drawLegend(cv::Mat& image, const std::vector<std::pair<std::string, cv::Scalar>>& entries,
               const std::vector<std::string>& notes, double font_scale, cv::Point origin) {
  const int line_height = legendLineHeight(font_scale);
  const cv::Rect box(origin, measureLegend(entries, notes, font_scale));
  cv::Mat roi = image(box & cv::Rect(0, 0, image.cols, image.rows));
  cv::Mat shade(roi.size(), roi.type(), cv::Scalar(255, 255, 255));
  cv::addWeighted(roi, 0.25, shade, 0.75, 0, roi);
  cv::rectangle(image, box, cv::Scalar(120, 120, 120), 1);
  int y = origin.y + 5 + line_height * 3 / 4;
  for (const auto& [text, colour] : entries) {
    cv::rectangle(image, cv::Rect(origin.x + 8, y - line_height / 2, 16, line_height / 2), colour,
                  cv::FILLED);
    cv::putText(image, text, cv::Point(origin.x + 32, y), kFont, font_scale, kBlack, 1,
                cv::LINE_AA);
    y += line_height;
  }
  for (const std::string& note : notes) {
    cv::putText(image, note, cv::Point(origin.x + 8, y), kFont, font_scale, kBlack, 1, cv::LINE_AA);
    y += line_height;
  }
  return box.height;
}

int FisheyeCheck::associated() const {
  return static_cast<int>(std::count_if(
      cameras.begin(), cameras.end(), [](const ProjectedCamera& c) { return c.blob.has_value(); }));
}

double FisheyeCheck::worstResidualAfter() const {
  double worst = 0;
  for (const ProjectedCamera& c : cameras) {
    if (c.blob && c.after) worst = std::max(worst, (*c.blob - *c.after).norm());
  }
  return worst;
}

cv::Mat drawFisheyeCheck(const FisheyeCheck& check, const cv::Mat& image, cv::Size out_size,
                         std::vector<OverlayMark>* marks) {
  const cv::Size in_size = image.empty() ? check.image_size : image.size();
  if (out_size.width <= 0 || out_size.height <= 0) out_size = in_size;
  cv::Mat canvas = resizeTo(toBgr(image, in_size), out_size);
  const PixelScale scale{static_cast<double>(out_size.width) / in_size.width,
                         static_cast<double>(out_size.height) / in_size.height};
  const double font = fontScaleFor(out_size);
  const int unit = std::max(2, out_size.width / 320);  // marker size unit [output px]
  const auto mark = [&](const char* kind, const std::string& label, cv::Point2d at,
                        const cv::Scalar& colour) {
    if (marks) marks->push_back({kind, label, at, colour});
  };

  // Legend with the frame's numbers and a 10 px (source image) scale bar,
  // drawn first: the overlays stay visible where they cross it.
  std::vector<std::string> notes;
  notes.push_back("frame " + std::to_string(check.frame_index) +
                  ", t = " + formatFixed(check.seconds, 2) + " s" +
                  (check.why.empty() ? "" : " (" + check.why + ")"));
  int associated = 0;
  double sum_before = 0, sum_after = 0;
  int n_before = 0, n_after = 0;
  for (const auto& c : check.cameras) {
    if (!c.blob) continue;
    ++associated;
    if (c.before) sum_before += (*c.blob - *c.before).squaredNorm(), ++n_before;
    if (c.after) sum_after += (*c.blob - *c.after).squaredNorm(), ++n_after;
  }
  notes.push_back(std::to_string(check.cameras.size()) + " cameras in view, " +
                  std::to_string(associated) + " with a blob");
  if (n_before || n_after) {
    notes.push_back(
        "RMS before " + (n_before ? formatFixed(std::sqrt(sum_before / n_before), 1) : "-") +
        " px, after " + (n_after ? formatFixed(std::sqrt(sum_after / n_after), 1) : "-") + " px");
  }
  if (image.empty()) notes.push_back("no image in the dataset: detections only");
  const int legend_height = drawLegend(canvas,
                                       {{"detected blob", colours::kBlob},
                                        {"camera position before refinement", colours::kBefore},
                                        {"camera position after refinement", colours::kAfter},
                                        {"residual (blob to after)", colours::kResidual}},
                                       {}, font, cv::Point(4, 4));
  const cv::Size notes_size = measureLegend({}, notes, font);
  drawLegend(canvas, {}, notes, font, cv::Point(4, out_size.height - notes_size.height - 4));
  const int bar = static_cast<int>(std::lround(10 * scale.sx));
  const cv::Point bar_at(12, 4 + legend_height + 12);
  cv::line(canvas, bar_at, bar_at + cv::Point(bar, 0), kWhite, 3);
  outlinedText(canvas, "10 px", bar_at + cv::Point(bar + 6, 5), font);
  // Residual segments first, so that the markers sit on top of them.
  for (const auto& c : check.cameras) {
    if (c.blob && c.after) {
      cv::line(canvas, rounded(scale(*c.blob)), rounded(scale(*c.after)), colours::kResidual,
               std::max(1, unit / 2), cv::LINE_AA);
    }
    if (c.blob && c.before) {
      cv::line(canvas, rounded(scale(*c.blob)), rounded(scale(*c.before)), colours::kBefore, 1,
               cv::LINE_AA);
    }
  }
  // Detected blobs: green rings around the blob (the blob itself stays visible).
  const int ring = 4 * unit;
  for (const Eigen::Vector2d& blob : check.blobs) {
    const cv::Point2d at = scale(blob);
    cv::circle(canvas, rounded(at), ring, colours::kBlob, std::max(2, unit / 2), cv::LINE_8);
    mark("blob", "", at, colours::kBlob);
  }
  for (const auto& c : check.cameras) {
    if (c.blob && std::none_of(check.blobs.begin(), check.blobs.end(),
                               [&](const auto& b) { return (b - *c.blob).norm() < 1e-9; })) {
      const cv::Point2d at = scale(*c.blob);
      cv::circle(canvas, rounded(at), ring, colours::kBlob, std::max(2, unit / 2), cv::LINE_8);
      mark("blob", c.label, at, colours::kBlob);
    }
  }
  // Labels under the markers, so that no label hides a projection.
  for (const auto& c : check.cameras) {
    const std::optional<Eigen::Vector2d>& anchor = c.after ? c.after : c.before;
    if (!anchor) continue;
    const cv::Point at = rounded(scale(*anchor)) + cv::Point(5 * unit, -3 * unit);
    outlinedText(canvas, c.label, at, font);
  }

  // Before: red crosses. After: blue discs, drawn last.
  for (const auto& c : check.cameras) {
    if (!c.before) continue;
    const cv::Point2d at = scale(*c.before);
    drawCross(canvas, rounded(at), 3 * unit, colours::kBefore, std::max(2, unit / 2));
    mark("before", c.label, at, colours::kBefore);
  }
  for (const auto& c : check.cameras) {
    if (!c.after) continue;
    const cv::Point2d at = scale(*c.after);
    cv::circle(canvas, rounded(at), 2 * unit + 1, colours::kAfter, cv::FILLED, cv::LINE_8);
    mark("after", c.label, at, colours::kAfter);
  }
  return canvas;
}

cv::Mat drawEnvCameraView(const EnvCameraView& view, const Camera& camera, const cv::Mat& image,
                          cv::Size out_size, std::vector<OverlayMark>* marks) {
  const cv::Size in_size = image.empty() ? cv::Size(camera.width(), camera.height()) : image.size();
  if (out_size.width <= 0 || out_size.height <= 0) out_size = in_size;
  cv::Mat canvas = resizeTo(toBgr(image, in_size), out_size);
  const PixelScale scale{static_cast<double>(out_size.width) / in_size.width,
                         static_cast<double>(out_size.height) / in_size.height};
  const double font = fontScaleFor(out_size);
  const int thickness = std::max(2, out_size.width / 400);
  const double half = view.marker_size_m / 2;

  const auto drawMarker = [&](const Rigid3d& camera_from_marker, const cv::Scalar& outline,
                              bool axes, const char* kind) {
    const auto project = [&](const Eigen::Vector3d& p_in_marker) -> std::optional<cv::Point2d> {
      const std::optional<Eigen::Vector2d> uv = camera.project(camera_from_marker * p_in_marker);
      if (!uv) return std::nullopt;
      return scale(*uv);
    };
    const std::vector<Eigen::Vector3d> corners = {
        {-half, half, 0}, {half, half, 0}, {half, -half, 0}, {-half, -half, 0}};
    std::vector<cv::Point> polygon;
    for (const Eigen::Vector3d& corner : corners) {
      if (const auto p = project(corner)) polygon.push_back(rounded(*p));
    }
    if (polygon.size() == 4) {
      cv::polylines(canvas, polygon, true, outline, thickness, cv::LINE_AA);
    }
    const std::optional<cv::Point2d> origin = project(Eigen::Vector3d::Zero());
    if (!origin) return;
    if (axes) {
      const double length = view.marker_size_m;
      const std::pair<Eigen::Vector3d, cv::Scalar> axis_list[] = {
          {Eigen::Vector3d(length, 0, 0), cv::Scalar(0, 0, 255)},
          {Eigen::Vector3d(0, length, 0), cv::Scalar(0, 200, 0)},
          {Eigen::Vector3d(0, 0, length), cv::Scalar(255, 0, 0)}};
      for (const auto& [tip, colour] : axis_list) {
        if (const auto p = project(tip)) {
          cv::arrowedLine(canvas, rounded(*origin), rounded(*p), colour, thickness, cv::LINE_AA, 0,
                          0.15);
        }
      }
    } else {
      drawCross(canvas, rounded(*origin), 3 * thickness, outline, thickness);
    }
    if (marks) marks->push_back({kind, view.camera, *origin, outline});
  };

  if (view.predicted_camera_from_marker) {
    drawMarker(*view.predicted_camera_from_marker, colours::kPredictedMarker, false,
               "marker_predicted");
  }
  if (view.detected_camera_from_marker) {
    drawMarker(*view.detected_camera_from_marker, colours::kDetectedMarker, true,
               "marker_detected");
  }
  std::vector<std::pair<std::string, cv::Scalar>> entries;
  if (view.detected_camera_from_marker) {
    entries.push_back({"detected marker (axes x red, y green, z blue)", colours::kDetectedMarker});
  }
  entries.push_back({"marker where the registration puts it", colours::kPredictedMarker});
  std::vector<std::string> notes = {view.camera};
  if (!view.detected_camera_from_marker) notes.push_back("no marker detection at this frame");
  if (image.empty()) notes.push_back("no image in the dataset: detections only");
  const cv::Size legend = measureLegend(entries, notes, font);
  drawLegend(canvas, entries, notes, font, cv::Point(4, out_size.height - legend.height - 4));
  return canvas;
}

namespace {

/// World (metres) -> plot pixels with equal scale on both axes.
struct PlotFrame {
  cv::Rect area;  ///< Pixels of the plotting area.
  double min_a = 0, min_b = 0, pixels_per_metre = 1;
  double span_b = 0;
  cv::Point2d operator()(double a, double b) const {
    return {area.x + (a - min_a) * pixels_per_metre,
            area.y + area.height - (b - min_b) * pixels_per_metre};
  }
};

PlotFrame fitFrame(const cv::Rect& area, double min_a, double max_a, double min_b, double max_b) {
  const double margin = 0.06 * std::max({max_a - min_a, max_b - min_b, 1.0});
  min_a -= margin, max_a += margin, min_b -= margin, max_b += margin;
  PlotFrame frame;
  frame.area = area;
  frame.pixels_per_metre = std::min(area.width / std::max(max_a - min_a, 1e-6),
                                    area.height / std::max(max_b - min_b, 1e-6));
  // Centre the content.
  const double used_a = (max_a - min_a) * frame.pixels_per_metre;
  const double used_b = (max_b - min_b) * frame.pixels_per_metre;
  frame.min_a = min_a - (area.width - used_a) / 2 / frame.pixels_per_metre;
  frame.min_b = min_b - (area.height - used_b) / 2 / frame.pixels_per_metre;
  return frame;
}

double niceStep(double metres) {
  const double magnitude = std::pow(10.0, std::floor(std::log10(std::max(metres, 1e-9))));
  for (double m : {1.0, 2.0, 5.0, 10.0}) {
    if (m * magnitude >= metres) return m * magnitude;
  }
  return 10 * magnitude;
}

std::string metresText(double metres) {
  if (metres >= 1) return formatFixed(metres, metres == std::floor(metres) ? 0 : 1) + " m";
  if (metres >= 0.01) return formatFixed(metres * 100, 0) + " cm";
  return formatFixed(metres * 1000, 0) + " mm";
}

/// One panel: axes a (right) and b (up) are two coordinates of the world.
/// Returns the frame used, so that a second panel can share its horizontal
/// scale (`same_horizontal`: the top view's frame, for the side view).
PlotFrame drawPanel(cv::Mat& canvas, const cv::Rect& area, int axis_a, int axis_b,
                    const std::string& panel_title, const std::vector<PlotCameras>& cameras,
                    const std::vector<PlotTrajectory>& trajectories, double font,
                    std::vector<OverlayMark>* marks, const PlotFrame* same_horizontal = nullptr) {
  double min_a = 1e300, max_a = -1e300, min_b = 1e300, max_b = -1e300;
  const auto extend = [&](const Eigen::Vector3d& p) {
    min_a = std::min(min_a, p[axis_a]), max_a = std::max(max_a, p[axis_a]);
    min_b = std::min(min_b, p[axis_b]), max_b = std::max(max_b, p[axis_b]);
  };
  for (const auto& set : cameras) {
    for (const auto& [label, p] : set.positions) extend(p);
  }
  for (const auto& t : trajectories) {
    for (const auto& p : t.positions) extend(p);
  }
  if (min_a > max_a) min_a = max_a = min_b = max_b = 0;
  PlotFrame frame = fitFrame(area, min_a, max_a, min_b, max_b);
  if (same_horizontal &&
      (max_b - min_b) * same_horizontal->pixels_per_metre <= area.height * 0.95) {
    // Same horizontal scale and offset as the other panel, vertically centred.
    frame.pixels_per_metre = same_horizontal->pixels_per_metre;
    frame.min_a = same_horizontal->min_a;
    frame.min_b = (min_b + max_b) / 2 - area.height / 2.0 / frame.pixels_per_metre;
  }

  cv::rectangle(canvas, area, cv::Scalar(160, 160, 160), 1);
  // Grid at a round step, about 8 lines across.
  const double step = niceStep(area.width / frame.pixels_per_metre / 8);
  for (double a = std::ceil(frame.min_a / step) * step;
       a < frame.min_a + area.width / frame.pixels_per_metre; a += step) {
    const int x = static_cast<int>(std::lround(frame(a, 0).x));
    cv::line(canvas, {x, area.y}, {x, area.y + area.height}, kGrid, 1);
  }
  for (double b = std::ceil(frame.min_b / step) * step;
       b < frame.min_b + area.height / frame.pixels_per_metre; b += step) {
    const int y = static_cast<int>(std::lround(frame(0, b).y));
    cv::line(canvas, {area.x, y}, {area.x + area.width, y}, kGrid, 1);
  }
  const char* names = "xyz";
  cv::putText(canvas,
              panel_title + " (" + names[axis_a] + " right, " + names[axis_b] + " up; grid " +
                  metresText(step) + ")",
              {area.x + 6, area.y + 18}, kFont, font, kBlack, 1, cv::LINE_AA);

  for (const auto& t : trajectories) {
    std::vector<cv::Point> points;
    for (const auto& p : t.positions) points.push_back(rounded(frame(p[axis_a], p[axis_b])));
    if (points.size() >= 2)
      cv::polylines(canvas, points, false, t.colour, t.thickness, cv::LINE_AA);
  }
  // Lines between corresponding cameras of the first two sets.
  if (cameras.size() >= 2) {
    for (const auto& [label, p] : cameras[0].positions) {
      for (const auto& [other_label, q] : cameras[1].positions) {
        if (label != other_label) continue;
        cv::line(canvas, rounded(frame(p[axis_a], p[axis_b])), rounded(frame(q[axis_a], q[axis_b])),
                 kBlack, 1, cv::LINE_AA);
      }
    }
  }
  const int radius = std::max(3, area.width / 220);
  for (size_t s = 0; s < cameras.size(); ++s) {
    const PlotCameras& set = cameras[s];
    for (const auto& [label, p] : set.positions) {
      const cv::Point2d at = frame(p[axis_a], p[axis_b]);
      if (set.filled) {
        cv::circle(canvas, rounded(at), radius, set.colour, cv::FILLED, cv::LINE_AA);
      } else {
        cv::rectangle(canvas,
                      cv::Rect(rounded(at) - cv::Point(radius + 2, radius + 2),
                               cv::Size(2 * radius + 5, 2 * radius + 5)),
                      set.colour, 2);
      }
      if (s == 0) {
        cv::putText(canvas, label, rounded(at) + cv::Point(radius + 3, -radius - 2), kFont,
                    font * 0.8, kBlack, 1, cv::LINE_AA);
      }
      if (marks && axis_b == 1) marks->push_back({"camera", label, at, set.colour});
    }
  }
  // Scale bar, bottom right.
  const double bar_m = niceStep(area.width / frame.pixels_per_metre / 6);
  const int bar_px = static_cast<int>(std::lround(bar_m * frame.pixels_per_metre));
  const cv::Point bar_end(area.x + area.width - 12, area.y + area.height - 14);
  cv::line(canvas, bar_end - cv::Point(bar_px, 0), bar_end, kBlack, 3);
  cv::line(canvas, bar_end - cv::Point(bar_px, 5), bar_end - cv::Point(bar_px, -5), kBlack, 2);
  cv::line(canvas, bar_end - cv::Point(0, 5), bar_end + cv::Point(0, 5), kBlack, 2);
  int baseline = 0;
  const std::string text = metresText(bar_m);
  const cv::Size text_size = cv::getTextSize(text, kFont, font, 1, &baseline);
  cv::putText(canvas, text, bar_end - cv::Point(bar_px / 2 + text_size.width / 2, 9), kFont, font,
              kBlack, 1, cv::LINE_AA);
  return frame;
}

std::vector<std::pair<std::string, cv::Scalar>> legendEntries(
    const std::vector<PlotCameras>& cameras, const std::vector<PlotTrajectory>& trajectories) {
  std::vector<std::pair<std::string, cv::Scalar>> entries;
  for (const auto& set : cameras) entries.push_back({set.name, set.colour});
  for (const auto& t : trajectories) entries.push_back({t.name, t.colour});
  return entries;
}

}  // namespace

cv::Mat drawTopSideView(const std::string& title, const std::vector<PlotCameras>& cameras,
                        const std::vector<PlotTrajectory>& trajectories, cv::Size out_size,
                        std::vector<OverlayMark>* marks) {
  cv::Mat canvas(out_size, CV_8UC3, kWhite);
  const double font = fontScaleFor(out_size);
  const int title_height = 30;
  cv::putText(canvas, title, {10, 22}, kFont, font * 1.1, kBlack, 1, cv::LINE_AA);
  const int usable = out_size.height - title_height - 10;
  const auto entries = legendEntries(cameras, trajectories);
  const cv::Size legend = measureLegend(entries, {}, font);
  const int panel_width = std::max(out_size.width / 2, out_size.width - legend.width - 30);
  // Split the height between the views in proportion to what they show, so
  // that both can use the same scale (equal metres per pixel).
  double lo[3] = {1e300, 1e300, 1e300}, hi[3] = {-1e300, -1e300, -1e300};
  const auto extend = [&](const Eigen::Vector3d& p) {
    for (int i = 0; i < 3; ++i) lo[i] = std::min(lo[i], p[i]), hi[i] = std::max(hi[i], p[i]);
  };
  for (const auto& set : cameras) {
    for (const auto& [label, p] : set.positions) extend(p);
  }
  for (const auto& t : trajectories) {
    for (const auto& p : t.positions) extend(p);
  }
  double top_share = 0.6;
  if (lo[0] <= hi[0]) {
    const double x = hi[0] - lo[0], y = hi[1] - lo[1], z = hi[2] - lo[2];
    const double top_needed = y + 0.12 * std::max({x, y, 1.0});
    const double side_needed = z + 0.12 * std::max({x, z, 1.0});
    top_share = std::clamp(top_needed / (top_needed + side_needed), 0.5, 0.85);
  }
  const cv::Rect top(10, title_height, panel_width, static_cast<int>(usable * top_share) - 5);
  const cv::Rect side(10, top.y + top.height + 10, panel_width, usable - top.height - 10);
  const PlotFrame top_frame =
      drawPanel(canvas, top, 0, 1, "top view", cameras, trajectories, font, marks);
  drawPanel(canvas, side, 0, 2, "side view", cameras, trajectories, font, nullptr, &top_frame);
  drawLegend(canvas, entries, {}, font, cv::Point(top.x + top.width + 10, top.y));
  return canvas;
}

cv::Mat drawTopView(const std::string& title, const std::vector<PlotCameras>& cameras,
                    const std::vector<PlotTrajectory>& trajectories, cv::Size out_size,
                    std::vector<OverlayMark>* marks) {
  cv::Mat canvas(out_size, CV_8UC3, kWhite);
  const double font = fontScaleFor(out_size);
  cv::putText(canvas, title, {10, 22}, kFont, font * 1.1, kBlack, 1, cv::LINE_AA);
  const auto entries = legendEntries(cameras, trajectories);
  const cv::Size legend = measureLegend(entries, {}, font);
  const int panel_width = std::max(out_size.width / 2, out_size.width - legend.width - 30);
  const cv::Rect top(10, 30, panel_width, out_size.height - 40);
  drawPanel(canvas, top, 0, 1, "top view", cameras, trajectories, font, marks);
  drawLegend(canvas, entries, {}, font, cv::Point(top.x + top.width + 10, top.y));
  return canvas;
}

}  // namespace lookboth::report
