#pragma once

#include <Eigen/Core>

#include "autograd/autograd.h"

namespace maps::core {

// Observation standardisation with statistics of the training demonstrations: (x - mean) / std per dimension,
// where a dimension that never varies gets std 1 (it is then only centred), then, when clip > 0, clamped to
// [-clip, clip]. Stored in checkpoints. The clamp is for dimensions the demonstrations barely vary in: MT10's object
// quaternion has a std of 4e-4 over the demonstrations, so a policy that knocks the object over sees inputs in the
// hundreds (docs/adversarial.md, "Observations out of the demonstrations' range").
struct Standardizer {
  Eigen::VectorXd mean;
  Eigen::VectorXd std;
  double clip = 0.0;  // 0: no clamp (every run made before data.observation_clip)

  // Fits mean and std (population) to the rows of `samples` [n, S].
  static Standardizer fit(const Eigen::MatrixXd& samples);
  // Rows of `observations` [n, S] standardised, as a tensor of `dtype`.
  ag::Tensor apply(const Eigen::MatrixXd& observations, ag::Dtype dtype) const;
  Eigen::VectorXd apply(const Eigen::VectorXd& observation) const;
  std::int64_t size() const { return mean.size(); }
};

}  // namespace maps::core
