#include "maps/data/standardizer.h"

#include <stdexcept>
#include <string>

namespace maps::core {

namespace {
// Below this the dimension is taken as constant: dividing by a tiny std would blow rounding noise up.
constexpr double kMinStd = 1e-6;
}  // namespace

Standardizer Standardizer::fit(const Eigen::MatrixXd& samples) {
  if (samples.rows() < 1) throw std::invalid_argument("Standardizer::fit: no samples");
  Standardizer s;
  s.mean = samples.colwise().mean().transpose();
  s.std = ((samples.rowwise() - s.mean.transpose()).array().square().colwise().mean()).sqrt().transpose();
  for (Eigen::Index i = 0; i < s.std.size(); ++i)
    if (!(s.std[i] >= kMinStd)) s.std[i] = 1.0;
  return s;
}

Eigen::VectorXd Standardizer::apply(const Eigen::VectorXd& observation) const {
  if (observation.size() != mean.size())
    throw std::invalid_argument("Standardizer: observation has " + std::to_string(observation.size()) +
                                " entries, expected " + std::to_string(mean.size()));
  const Eigen::VectorXd standardised = (observation - mean).cwiseQuotient(std);
  return clip > 0.0 ? Eigen::VectorXd(standardised.cwiseMax(-clip).cwiseMin(clip)) : standardised;
}

ag::Tensor Standardizer::apply(const Eigen::MatrixXd& observations, ag::Dtype dtype) const {
  if (observations.cols() != mean.size())
    throw std::invalid_argument("Standardizer: observations have " + std::to_string(observations.cols()) +
                                " columns, expected " + std::to_string(mean.size()));
  Eigen::MatrixXd standardised =
      (observations.rowwise() - mean.transpose()).array().rowwise() / std.transpose().array();
  if (clip > 0.0) standardised = standardised.cwiseMax(-clip).cwiseMin(clip);
  const ag::Tensor out = ag::from_eigen(standardised);
  return out.to(dtype);
}

}  // namespace maps::core
