#include "maps/rl/running_mean_std.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace maps::rl {

RunningMeanStd::RunningMeanStd(int size, double initial_count)
    : mean_(Eigen::VectorXd::Zero(size)), var_(Eigen::VectorXd::Ones(size)), count_(initial_count) {
  if (size < 0) throw std::invalid_argument("RunningMeanStd: negative size " + std::to_string(size));
}

void RunningMeanStd::update(const Eigen::VectorXd& x) { update_from_moments(x, Eigen::VectorXd::Zero(x.size()), 1.0); }

void RunningMeanStd::update_batch(const Eigen::MatrixXd& rows) {
  if (rows.rows() == 0) return;
  const Eigen::VectorXd batch_mean = rows.colwise().mean().transpose();
  const Eigen::VectorXd batch_var =
      (rows.rowwise() - batch_mean.transpose()).array().square().colwise().mean().transpose();
  update_from_moments(batch_mean, batch_var, static_cast<double>(rows.rows()));
}

void RunningMeanStd::update_from_moments(const Eigen::VectorXd& batch_mean, const Eigen::VectorXd& batch_var,
                                         double batch_count) {
  if (batch_mean.size() != mean_.size() || batch_var.size() != mean_.size())
    throw std::invalid_argument("RunningMeanStd: got a vector of size " + std::to_string(batch_mean.size()) +
                                ", expected " + std::to_string(mean_.size()));
  const Eigen::VectorXd delta = batch_mean - mean_;
  const double total = count_ + batch_count;
  const Eigen::VectorXd m2 =
      var_ * count_ + batch_var * batch_count + delta.cwiseProduct(delta) * (count_ * batch_count / total);
  mean_ += delta * (batch_count / total);
  var_ = m2 / total;
  count_ = total;
}

Eigen::VectorXd RunningMeanStd::normalize(const Eigen::VectorXd& x) const {
  if (x.size() != mean_.size())
    throw std::invalid_argument("RunningMeanStd::normalize: got a vector of size " + std::to_string(x.size()) +
                                ", expected " + std::to_string(mean_.size()));
  return ((x - mean_).array() / (var_.array() + epsilon).sqrt()).cwiseMax(-clip).cwiseMin(clip).matrix();
}

void RunningMeanStd::set_state(const Eigen::VectorXd& mean, const Eigen::VectorXd& var, double count) {
  if (mean.size() != var.size()) throw std::invalid_argument("RunningMeanStd::set_state: mean and var sizes differ");
  mean_ = mean;
  var_ = var;
  count_ = count;
}

double RewardScaler::scale(double reward, bool episode_ended) {
  return_ = return_ * gamma_ + reward;
  stats_.update(Eigen::VectorXd::Constant(1, return_));
  const double scaled = std::clamp(reward / std(), -clip, clip);
  if (episode_ended) return_ = 0.0;
  return scaled;
}

double RewardScaler::std() const { return std::sqrt(stats_.var()(0) + epsilon); }

}  // namespace maps::rl
