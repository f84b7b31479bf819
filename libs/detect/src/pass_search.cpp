#include "lookboth/detect/pass_search.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

namespace lookboth {

std::size_t coarseStep(const std::vector<TimeNs>& times, double period_s) {
  if (!(period_s > 0) || times.size() < 2) return 1;
  std::vector<TimeNs> intervals;
  intervals.reserve(times.size() - 1);
  for (std::size_t i = 1; i < times.size(); ++i) intervals.push_back(times[i] - times[i - 1]);
  std::nth_element(intervals.begin(), intervals.begin() + intervals.size() / 2, intervals.end());
  const double interval_s = static_cast<double>(intervals[intervals.size() / 2]) * 1e-9;
  if (!(interval_s > 0)) return 1;
  return static_cast<std::size_t>(std::max(1.0, std::floor(period_s / interval_s + 1e-6)));
}

PassSearch::PassSearch(std::size_t frames, std::size_t step)
    : state_(frames, kUnseen), step_(std::max<std::size_t>(1, step)) {
  for (std::size_t i = 0; i < frames; i += step_) coarse_.push_back(i);
  if (frames > 0 && coarse_.back() != frames - 1) coarse_.push_back(frames - 1);
}

PassSearch::PassSearch(std::size_t frames, std::size_t step, std::vector<std::size_t> coarse)
    : state_(frames, kUnseen), step_(std::max<std::size_t>(1, step)), coarse_(std::move(coarse)) {
  coarse_.erase(std::remove_if(coarse_.begin(), coarse_.end(),
                               [frames](std::size_t i) { return i >= frames; }),
                coarse_.end());
  std::sort(coarse_.begin(), coarse_.end());
  // The last frame too: a pass at the very end has no coarse frame after it.
  if (frames > 0 && (coarse_.empty() || coarse_.back() != frames - 1))
    coarse_.push_back(frames - 1);
}

bool PassSearch::look(std::size_t i, bool coarse) {
  if (state_[i] == kUnseen) {
    state_[i] = (*examine_)(i, coarse) ? kFound : kEmpty;
    ++examined_;
  }
  return state_[i] == kFound;
}

std::ptrdiff_t PassSearch::walk(std::ptrdiff_t from, std::ptrdiff_t to, std::ptrdiff_t direction) {
  std::size_t empty = 0;
  std::ptrdiff_t i = from;
  for (; i != to && empty < step_ && !stop_->load(); i += direction) {
    empty = look(static_cast<std::size_t>(i), false) ? 0 : empty + 1;
  }
  return i;
}

void PassSearch::run(const Examine& examine, const std::atomic<bool>& stop) {
  examine_ = &examine;
  stop_ = &stop;
  const auto n = static_cast<std::ptrdiff_t>(state_.size());
  std::ptrdiff_t resume = 0;  // frames before it were walked over
  for (const std::size_t c : coarse_) {
    const auto i = static_cast<std::ptrdiff_t>(c);
    if (stop.load()) break;
    if (i < resume || !look(c, true)) continue;
    walk(i - 1, -1, -1);
    resume = walk(i + 1, n, 1);
  }
  examine_ = nullptr;
  stop_ = nullptr;
}

SceneChange::SceneChange(double threshold_grey, int reduction)
    : threshold_(threshold_grey), reduction_(std::max(1, reduction)) {}

bool SceneChange::changed(const cv::Mat& grey) {
  if (!(threshold_ > 0)) {
    candidate_.release();
    return true;
  }
  return difference(grey) > threshold_;
}

double SceneChange::difference(const cv::Mat& grey) {
  constexpr double kIncomparable = std::numeric_limits<double>::infinity();
  candidate_.release();
  if (grey.empty() || grey.channels() != 1) return kIncomparable;
  const cv::Size size(std::max(1, grey.cols / reduction_), std::max(1, grey.rows / reduction_));
  cv::Mat reduced;
  cv::resize(grey, reduced, size, 0, 0, cv::INTER_AREA);
  reduced.convertTo(candidate_, CV_32F);
  if (reference_.empty() || reference_.size() != candidate_.size()) return kIncomparable;
  // Far darker or brighter (the means' ratio): a marker's contrast may have
  // shrunk with the light; searched.
  const double mean_now = cv::mean(candidate_)[0];
  if (!(mean_now > kMinGain * reference_mean_ && reference_mean_ > kMinGain * mean_now))
    return kIncomparable;
  // The exposure (gain and offset) fitted by least squares: an automatic
  // exposure changes every pixel alike, the robot a part of the view.
  const cv::Mat now = candidate_ - mean_now;
  const double gain = reference_spread_ > 0 ? now.dot(reference_) / reference_spread_ : 1.0;
  return cv::norm(now - gain * reference_, cv::NORM_INF);
}

void SceneChange::keep() {
  if (candidate_.empty()) return;
  reference_mean_ = cv::mean(candidate_)[0];
  reference_ = candidate_ - reference_mean_;
  reference_spread_ = reference_.dot(reference_);
}

void SceneChange::forget() { reference_.release(); }

}  // namespace lookboth
