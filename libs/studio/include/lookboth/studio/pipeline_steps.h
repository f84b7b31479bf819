// The desktop app's pipeline steps and what became of each, without a window
// (so the sequencing is tested without wx): detect, odometry, then the
// configured registration stages, as RegistrationPipeline runs them (its
// "output" step goes with the last stage). A step runs once every step
// before it has run or was not needed.
#pragma once
#include <cstddef>
#include <string>
#include <vector>

namespace lookboth::studio {

class PipelineSteps {
 public:
  enum class State { kPending, kDone, kSkipped };
  struct Step {
    std::string name;  ///< "detect", "odometry", or a stage ("look_down"...).
    State state = State::kPending;
    std::string note;  ///< What it did or why it was skipped.
  };

  /// detect, odometry, then `stages` in order.
  explicit PipelineSteps(const std::vector<std::string>& stages = {});

  std::size_t size() const { return steps_.size(); }
  const Step& operator[](std::size_t i) const { return steps_.at(i); }
  /// The first step still pending (the only one that may run); -1 when all have.
  int firstPending() const;
  bool allDone() const { return firstPending() < 0; }
  /// Index of the step named `name`; -1 when there is none.
  int index(const std::string& name) const;
  /// Whether step i is a registration stage (not detect or odometry).
  bool isStage(int i) const { return i >= kPreparationSteps && i < static_cast<int>(size()); }
  /// The names, comma-separated (for messages).
  std::string names() const;

  /// Step i has ended: done when it ran, else skipped (not needed).
  void finish(int i, bool ran, std::string note);
  /// Back to pending: the registration stages (keep_preparation: detection
  /// and odometry stay as they ended, their results are in the dataset), or every step.
  void reset(bool keep_preparation);

  /// Detect and odometry, before the stages.
  static constexpr int kPreparationSteps = 2;

 private:
  std::vector<Step> steps_;
};

}  // namespace lookboth::studio
