#include "lookboth/studio/pipeline_steps.h"

#include <stdexcept>

namespace lookboth::studio {

PipelineSteps::PipelineSteps(const std::vector<std::string>& stages) {
  steps_.push_back({"detect", State::kPending, ""});
  steps_.push_back({"odometry", State::kPending, ""});
  for (const std::string& stage : stages) steps_.push_back({stage, State::kPending, ""});
}

int PipelineSteps::firstPending() const {
  for (std::size_t i = 0; i < steps_.size(); ++i)
    if (steps_[i].state == State::kPending) return static_cast<int>(i);
  return -1;
}

int PipelineSteps::index(const std::string& name) const {
  for (std::size_t i = 0; i < steps_.size(); ++i)
    if (steps_[i].name == name) return static_cast<int>(i);
  return -1;
}

std::string PipelineSteps::names() const {
  std::string text;
  for (const Step& step : steps_) text += (text.empty() ? "" : ", ") + step.name;
  return text;
}

void PipelineSteps::finish(int i, bool ran, std::string note) {
  Step& step = steps_.at(static_cast<std::size_t>(i));
  step.state = ran ? State::kDone : State::kSkipped;
  step.note = std::move(note);
}

void PipelineSteps::reset(bool keep_preparation) {
  for (std::size_t i = keep_preparation ? kPreparationSteps : 0; i < steps_.size(); ++i) {
    steps_[i].state = State::kPending;
    steps_[i].note.clear();
  }
}

}  // namespace lookboth::studio
