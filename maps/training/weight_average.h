#pragma once

#include <cstdint>
#include <string>

#include "maps/training/checkpoint_record.h"
#include "nn/module.h"

// An exponential moving average of a policy's parameters, as Diffusion Policy keeps and evaluates (its EMAModel):
// after optimiser update n (n = 1, 2, ...) average = decay(n) average + (1 - decay(n)) parameter, with
// decay(n) = 1 - (n - 1)^-power capped at max_decay (0 for the first two updates, which copy the parameters). The
// trainer judges, keeps and evaluates the averaged parameters when train.ema_power is above 0 (issue 46; docs/zoo.md).
namespace maps::core {

class WeightAverage {
 public:
  // Starts as a copy of `parameters` (the policy's named parameters, shared storage).
  WeightAverage(nn::NamedTensors parameters, double power, double max_decay);

  // decay(n) for update n >= 1 (see above).
  static double decay(std::int64_t update, double power, double max_decay);

  // After optimiser update `update` (1 for the first).
  void update(std::int64_t update);

  double power() const { return power_; }
  double max_decay() const { return max_decay_; }

  // The average's values under the parameters' names (copies in the parameters' dtypes, not shared with the policy).
  const nn::NamedTensors& values() const { return average_; }
  // Replaces the values (a resumed run's); throws naming `source` unless the names, shapes and dtypes match.
  void load(const nn::NamedTensors& values, const std::string& source);

  // Copies the average into the parameters for good (a finished run's policy as it is evaluated).
  void apply();

  // Swaps the average into the parameters for the scope (validation, best.ckpt), and the trained values back after;
  // a null average (a run keeping none) leaves the parameters alone.
  class Applied {
   public:
    explicit Applied(WeightAverage* average);
    ~Applied();
    Applied(const Applied&) = delete;
    Applied& operator=(const Applied&) = delete;

   private:
    WeightAverage* average_;
    nn::NamedTensors trained_;
  };

 private:
  nn::NamedTensors parameters_;  // the policy's
  nn::NamedTensors average_;
  double power_, max_decay_;
};

// Why a training checkpoint's average of the weights is read: to resume its run, or to evaluate its last step.
enum class AverageUse { kResume, kEvaluate };

// Holds a training checkpoint (`checkpoint`, its `state`, and whether it holds an average) to the average a run is
// set to keep (`power` 0: none; `max_decay`); `setting` names where the setting comes from ("this run", a run's
// config.json). Throws std::runtime_error naming both when the checkpoint holds an average and the setting keeps
// none or the reverse, or the recorded power or cap differ from the setting's.
void check_average_agrees(const std::string& checkpoint, const TrainingState& state, bool holds_average, double power,
                          double max_decay, const std::string& setting, AverageUse use);

}  // namespace maps::core
