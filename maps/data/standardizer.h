#pragma once

#include <Eigen/Core>

#include "autograd/autograd.h"

namespace maps::core {

// Observation standardisation with statistics of the training demonstrations: (x - mean) / std per dimension,
// where a dimension that never varies gets std 1 (it is then only centred). Stored in checkpoints.
struct Standardizer {
  Eigen::VectorXd mean;
  Eigen::VectorXd std;

  // Fits mean and std (population) to the rows of `samples` [n, S].
  static Standardizer fit(const Eigen::MatrixXd& samples);
  // Rows of `observations` [n, S] standardised, as a tensor of `dtype`.
  ag::Tensor apply(const Eigen::MatrixXd& observations, ag::Dtype dtype) const;
  Eigen::VectorXd apply(const Eigen::VectorXd& observation) const;
  std::int64_t size() const { return mean.size(); }
};

}  // namespace maps::core
