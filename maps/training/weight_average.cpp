#include "maps/training/weight_average.h"

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <utility>

#include "autograd/grad_mode.h"
#include "autograd/ops.h"

namespace maps::core {

namespace {

nn::NamedTensors copies_of(const nn::NamedTensors& tensors) {
  nn::NamedTensors copies;
  for (const auto& t : tensors) copies.push_back({t.name, t.tensor.detach().clone()});
  return copies;
}

}  // namespace

WeightAverage::WeightAverage(nn::NamedTensors parameters, double power, double max_decay)
    : parameters_(std::move(parameters)), average_(copies_of(parameters_)), power_(power), max_decay_(max_decay) {
  if (!(power > 0.0) || !std::isfinite(power))
    throw std::invalid_argument("train.ema_power: expected a power above 0 (0 keeps no average), got " +
                                std::to_string(power));
  if (!(max_decay >= 0.0 && max_decay < 1.0))
    throw std::invalid_argument(
        "train.ema_max_decay: expected a decay in [0, 1) (1 would never move the average), got " +
        std::to_string(max_decay));
}

double WeightAverage::decay(std::int64_t update, double power, double max_decay) {
  // EMAModel.get_decay's step is the updates before this one less one (its optimization_step counts from 0).
  const std::int64_t step = update - 2;
  if (step <= 0) return 0.0;
  return std::min(max_decay, 1.0 - std::pow(1.0 + static_cast<double>(step), -power));
}

void WeightAverage::update(std::int64_t update) {
  ag::NoGradGuard no_grad;
  const double d = decay(update, power_, max_decay_);
  for (std::size_t i = 0; i < average_.size(); ++i) {
    ag::Tensor& average = average_[i].tensor;
    average.copy_(average * d + parameters_[i].tensor.detach() * (1.0 - d));
  }
}

void WeightAverage::load(const nn::NamedTensors& values, const std::string& source) {
  if (values.size() != average_.size())
    throw std::runtime_error(source + ": holds " + std::to_string(values.size()) + " averaged parameters, the policy " +
                             std::to_string(average_.size()));
  for (std::size_t i = 0; i < values.size(); ++i) {
    const auto& [name, tensor] = values[i];
    if (name != average_[i].name || tensor.shape() != average_[i].tensor.shape() ||
        tensor.dtype() != average_[i].tensor.dtype())
      throw std::runtime_error(source + ": averaged parameter " + std::to_string(i) + " is " + name + " " +
                               ag::to_string(tensor.shape()) + " " + ag::to_string(tensor.dtype()) + ", the policy's " +
                               average_[i].name + " " + ag::to_string(average_[i].tensor.shape()) + " " +
                               ag::to_string(average_[i].tensor.dtype()));
  }
  average_ = copies_of(values);
}

void WeightAverage::apply() {
  ag::NoGradGuard no_grad;
  for (std::size_t i = 0; i < average_.size(); ++i) parameters_[i].tensor.copy_(average_[i].tensor);
}

WeightAverage::Applied::Applied(WeightAverage* average) : average_(average) {
  if (average_ == nullptr) return;
  trained_ = copies_of(average_->parameters_);
  average_->apply();
}

WeightAverage::Applied::~Applied() {
  if (average_ == nullptr) return;
  ag::NoGradGuard no_grad;
  for (std::size_t i = 0; i < trained_.size(); ++i) average_->parameters_[i].tensor.copy_(trained_[i].tensor);
}

void check_average_agrees(const std::string& checkpoint, const TrainingState& state, bool holds_average, double power,
                          double max_decay, const std::string& setting, AverageUse use) {
  const bool resuming = use == AverageUse::kResume;
  const auto text = [](double value) { return nlohmann::json(value).dump(); };
  const bool averages = power > 0.0;
  if (holds_average != averages)
    throw std::runtime_error("training checkpoint " + checkpoint + (holds_average ? " holds an" : " holds no") +
                             " average of the weights, and " + setting + " has train.ema_power " + text(power) +
                             (resuming ? ": a run resumes with the train.ema_power it began with" : ""));
  if (averages &&
      ((state.ema_power && *state.ema_power != power) || (state.ema_max_decay && *state.ema_max_decay != max_decay)))
    throw std::runtime_error("training checkpoint " + checkpoint + " averages the weights with train.ema_power " +
                             text(state.ema_power.value_or(power)) + " and ema_max_decay " +
                             text(state.ema_max_decay.value_or(max_decay)) + ", and " + setting + " has " +
                             text(power) + " and " + text(max_decay) +
                             (resuming ? ": a run resumes with the average it began with" : ""));
}

}  // namespace maps::core
