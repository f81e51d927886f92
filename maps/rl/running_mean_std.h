#pragma once

#include <Eigen/Core>
#include <cstdint>

// Running statistics for PPO's normalisers, after SB3's RunningMeanStd / gym's NormalizeObservation and
// NormalizeReward. Everything is float64.
namespace maps::rl {

// Mean and (population) variance of every vector seen so far, merged batch by batch with the parallel
// formula of Chan et al. Starts like SB3: mean 0, var 1, count 1e-4 (so the first batch dominates at once).
class RunningMeanStd {
 public:
  explicit RunningMeanStd(int size = 0, double initial_count = 1e-4);

  int size() const { return static_cast<int>(mean_.size()); }
  // One observation.
  void update(const Eigen::VectorXd& x);
  // A batch of observations, one per row.
  void update_batch(const Eigen::MatrixXd& rows);
  // Merges the statistics of a batch given as its mean, population variance and count.
  void update_from_moments(const Eigen::VectorXd& batch_mean, const Eigen::VectorXd& batch_var, double batch_count);

  // clip((x - mean) / sqrt(var + epsilon), -clip, clip).
  Eigen::VectorXd normalize(const Eigen::VectorXd& x) const;

  const Eigen::VectorXd& mean() const { return mean_; }
  const Eigen::VectorXd& var() const { return var_; }
  double count() const { return count_; }
  // For checkpoints.
  void set_state(const Eigen::VectorXd& mean, const Eigen::VectorXd& var, double count);

  double clip = 10.0;
  double epsilon = 1e-8;

 private:
  Eigen::VectorXd mean_;
  Eigen::VectorXd var_;
  double count_;
};

// Scales rewards by the running standard deviation of the discounted return, as SB3's VecNormalize (and gym's
// NormalizeReward): ret <- gamma * ret + r; the statistics absorb ret; the scaled reward is
// clip(r / sqrt(var(ret) + epsilon), -clip, clip); ret restarts at 0 after the episode ends (terminated or
// truncated).
class RewardScaler {
 public:
  explicit RewardScaler(double gamma = 0.99) : gamma_(gamma), stats_(1) {}

  double scale(double reward, bool episode_ended);
  double std() const;

  double discounted_return() const { return return_; }
  const RunningMeanStd& stats() const { return stats_; }
  void set_state(double discounted_return, const RunningMeanStd& stats) {
    return_ = discounted_return;
    stats_ = stats;
  }

  double clip = 10.0;
  double epsilon = 1e-8;

 private:
  double gamma_;
  double return_ = 0.0;
  RunningMeanStd stats_;
};

}  // namespace maps::rl
