#include "maps/training/weight_average.h"

#include <algorithm>
#include <cmath>
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

WeightAverage::Applied::Applied(WeightAverage* average) : average_(average) {
  if (average_ == nullptr) return;
  trained_ = copies_of(average_->parameters_);
  ag::NoGradGuard no_grad;
  for (std::size_t i = 0; i < trained_.size(); ++i) average_->parameters_[i].tensor.copy_(average_->average_[i].tensor);
}

WeightAverage::Applied::~Applied() {
  if (average_ == nullptr) return;
  ag::NoGradGuard no_grad;
  for (std::size_t i = 0; i < trained_.size(); ++i) average_->parameters_[i].tensor.copy_(trained_[i].tensor);
}

}  // namespace maps::core
