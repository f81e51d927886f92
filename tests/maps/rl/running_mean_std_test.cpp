#include "maps/rl/running_mean_std.h"

#include <algorithm>
#include <random>

#include "rl_test_util.h"

namespace rltest {
namespace {

using maps::rl::RewardScaler;
using maps::rl::RunningMeanStd;

Eigen::MatrixXd random_rows(int rows, int cols, std::mt19937_64& rng, double scale, double shift) {
  std::normal_distribution<double> n(0.0, 1.0);
  Eigen::MatrixXd m(rows, cols);
  for (int i = 0; i < rows; ++i)
    for (int j = 0; j < cols; ++j) m(i, j) = shift + scale * n(rng) * (j + 1);
  return m;
}

TEST(RunningMeanStd, MatchesBatchStatisticsOfConcatenatedData) {
  std::mt19937_64 rng(7);
  const Eigen::MatrixXd a = random_rows(13, 3, rng, 2.0, 5.0);
  const Eigen::MatrixXd b = random_rows(1, 3, rng, 0.5, -1.0);
  const Eigen::MatrixXd c = random_rows(40, 3, rng, 3.0, 0.0);
  Eigen::MatrixXd all(a.rows() + b.rows() + c.rows() + 1, 3);
  const Eigen::VectorXd single = Eigen::Vector3d(1.0, -2.0, 30.0);
  all << a, b, c, single.transpose();
  RunningMeanStd rms(3, /*initial_count=*/0.0);
  rms.update_batch(a);
  rms.update_batch(b);
  rms.update_batch(c);
  rms.update(single);
  const Eigen::VectorXd mean = all.colwise().mean().transpose();
  const Eigen::VectorXd var = (all.rowwise() - mean.transpose()).array().square().colwise().mean().transpose();
  EXPECT_LT((rms.mean() - mean).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT((rms.var() - var).cwiseAbs().maxCoeff(), 1e-10);
  EXPECT_DOUBLE_EQ(rms.count(), static_cast<double>(all.rows()));

  // SB3's prior (count 1e-4 at mean 0, var 1) barely moves the result.
  RunningMeanStd prior(3);
  prior.update_batch(all);
  EXPECT_LT((prior.mean() - mean).cwiseAbs().maxCoeff(), 1e-4);
  EXPECT_LT(((prior.var() - var).array() / var.array()).abs().maxCoeff(), 1e-4);
}

TEST(RunningMeanStd, NormalizeClipsAndUsesEpsilon) {
  RunningMeanStd rms(2, 0.0);
  rms.set_state(Eigen::Vector2d(1.0, 0.0), Eigen::Vector2d(4.0, 1e-6), 10.0);
  const Eigen::VectorXd z = rms.normalize(Eigen::Vector2d(5.0, 1.0));
  EXPECT_NEAR(z(0), 4.0 / std::sqrt(4.0 + 1e-8), 1e-12);
  EXPECT_EQ(z(1), 10.0);  // 1 / sqrt(1e-6) = 1000, clipped
  EXPECT_THROW(rms.normalize(Eigen::Vector3d::Zero()), std::invalid_argument);
}

TEST(RewardScaler, TracksTheDiscountedReturnAndRestartsAfterAnEpisode) {
  RewardScaler scaler(0.5);
  const double s1 = scaler.scale(1.0, false);
  EXPECT_DOUBLE_EQ(scaler.discounted_return(), 1.0);
  EXPECT_DOUBLE_EQ(s1, std::min(10.0, 1.0 / scaler.std()));  // clipped at 10
  scaler.scale(1.0, false);
  EXPECT_DOUBLE_EQ(scaler.discounted_return(), 1.5);
  const double s3 = scaler.scale(2.0, true);
  EXPECT_DOUBLE_EQ(scaler.discounted_return(), 0.0);
  EXPECT_DOUBLE_EQ(s3, std::min(10.0, 2.0 / scaler.std()));
  // The statistics saw the returns 1, 1.5, 2.75 (after the prior).
  EXPECT_NEAR(scaler.stats().mean()(0), (1.0 + 1.5 + 2.75) / (3.0 + 1e-4), 1e-4);
}

}  // namespace
}  // namespace rltest
