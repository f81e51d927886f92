#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace maps::core {

// A run's training cost as its curve.csv records it. The curve's rows survive resumes (a resumed run truncates it to
// its checkpoint's step and appends), so they sum every attempt and count steps redone after a kill once, where a
// process's own clock sees only its attempt and grows with pauses.
struct CurveCost {
  double seconds = 0.0;
  bool cpu = false;  // the cpu_seconds column (process CPU time); false: each window's steps over its steps_per_second
};

// The cost of training up to `steps` from the curve at `curve_path`. std::nullopt when the file is missing or
// unreadable, a window's time is not a positive number, or the rows do not end at `steps`.
std::optional<CurveCost> curve_training_cost(const std::string& curve_path, std::int64_t steps);

// A GAIL run's training cost from its curve: the sum of its iterations' cpu_seconds where the curve has the column
// (cpu true; curves written since 2026-12-05), else each iteration's env steps (its rise in env_steps_per_task over
// the row before, times `tasks`) over the env steps per second it logged (rollouts, discriminator and PPO; wall time,
// so cores shared with other runs count, cpu false), summed by sum_without_stops. std::nullopt when the file is
// missing or unreadable, the env steps do not rise row by row, a time is not a positive number, or the rows do not
// end at `env_steps_per_task`.
std::optional<CurveCost> gail_curve_training_cost(const std::string& curve_path, std::int64_t env_steps_per_task,
                                                  std::int64_t tasks);

// An iteration timed over kStoppedFactor times its run's median was a process stopped, not working (SIGSTOP while
// another job had the cores, a suspended machine), and costs the median. In results/adversarial's GAIL cells, work
// shared with other jobs slowed iterations to at most 14 times their run's median, stopped ones took 41 to 2,846
// times it (an MT10 iteration of 2 s took 1.9 hours).
inline constexpr double kStoppedFactor = 30.0;

// The sum of a run's iteration times with each stopped one (above kStoppedFactor x the median) at the median.
double sum_without_stops(const std::vector<double>& seconds);

}  // namespace maps::core
