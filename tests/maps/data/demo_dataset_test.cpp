#include "maps/data/demo_dataset.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>

#include "tests/maps/data/synthetic_demos.h"

namespace maps::core {
namespace {

using ::testing::HasSubstr;

TEST(DemoDataset, DrawsDemosBySeedAndSubsamplesFromAnOffset) {
  const envs::DemoFile file = synthetic_demo_file();
  DataConfig config;
  config.demos_per_task = 2;
  config.subsample = 10;
  config.seed = 3;
  const DemoDataset a(file, config), b(file, config);
  EXPECT_EQ(a.training_demo_seeds(), b.training_demo_seeds());  // the same seed, the same data
  for (int k = 0; k < 2; ++k) {
    ASSERT_EQ(a.training_demo_seeds()[k].size(), 2u);
    EXPECT_EQ(a.training_samples(k), 2 * 4);  // 40 steps, every 10th
    for (std::uint64_t seed : a.training_demo_seeds()[k]) EXPECT_LT(seed % 100, 4u) << "a validation demo was drawn";
  }
  std::set<std::vector<std::vector<std::uint64_t>>> draws;
  for (std::uint64_t seed = 0; seed < 8; ++seed) {
    config.seed = seed;
    draws.insert(DemoDataset(file, config).training_demo_seeds());
  }
  EXPECT_GT(draws.size(), 3u);                 // seeds redraw the demos
  EXPECT_EQ(a.validation_samples(0), 2 * 40);  // validation keeps every state
  EXPECT_DOUBLE_EQ(a.demo_mean_return(1), 80.0);
}

TEST(DemoDataset, BatchesAreBalancedStandardisedAndCarryThePreviousState) {
  const envs::DemoFile file = synthetic_demo_file();
  const DemoDataset data(file, DataConfig{});
  std::mt19937_64 rng(1);
  const Batch batch = data.sample(16, rng, ag::Dtype::Float64);
  ASSERT_EQ(batch.size(), 32);
  EXPECT_EQ(batch.per_task, 16);
  for (int j = 0; j < 32; ++j) EXPECT_EQ(batch.tasks[j], j < 16 ? 0 : 1);
  // The standardised training states have mean 0 and std 1 per dimension.
  Eigen::MatrixXd all(0, 3);
  for (int k = 0; k < 2; ++k) {
    std::mt19937_64 r(2);
    const Batch many = data.task_training_batch(k, 4000, r, ag::Dtype::Float64);
    const auto m = many.observations.matrix<double>();
    all.conservativeResize(all.rows() + m.rows(), 3);
    all.bottomRows(m.rows()) = m;
  }
  const Eigen::RowVectorXd mean = all.colwise().mean();
  EXPECT_LT(mean.cwiseAbs().maxCoeff(), 0.05);
  // A state and its predecessor, both standardised: consecutive rows of one demo differ by the step in column 2.
  const auto obs = batch.observations.matrix<double>(), prev = batch.previous_observations.matrix<double>();
  for (int j = 0; j < 32; ++j) {
    const double dt = (obs(j, 2) - prev(j, 2)) * data.standardizer().std[2];
    EXPECT_TRUE(std::abs(dt - 0.05) < 1e-9 || std::abs(dt) < 1e-12) << j;  // t - 1, or t = 0 paired with itself
  }
}

// With an action horizon H each row's actions are the chunk of its demonstration's next H actions (its own first),
// the last action repeated past the end; states, draws and validation rows are those of horizon 1.
TEST(DemoDataset, ChunksAreTheNextActionsOfTheRowsOwnDemoPaddedWithItsLast) {
  const envs::DemoFile file = synthetic_demo_file();
  DataConfig one;
  one.demos_per_task = 2;
  one.subsample = 7;
  one.seed = 4;
  DataConfig chunked = one;
  chunked.action_horizon = 5;
  const DemoDataset a(file, one), b(file, chunked);
  EXPECT_EQ(a.training_demo_seeds(), b.training_demo_seeds());
  EXPECT_EQ(b.action_size(), 2);
  EXPECT_EQ(b.action_horizon(), 5);
  for (int k = 0; k < 2; ++k) {
    const Batch va = a.task_validation_batch(k, ag::Dtype::Float64),
                vb = b.task_validation_batch(k, ag::Dtype::Float64);
    ASSERT_EQ(vb.actions.shape(), (ag::Shape{va.size(), 10}));
    EXPECT_EQ(va.observations.to_vector(), vb.observations.to_vector());
    const auto single = va.actions.matrix<double>(), chunks = vb.actions.matrix<double>();
    // Validation keeps every state of its demos in order, 40 per demo: row r's chunk is rows r .. r + 4 of its demo.
    for (Eigen::Index r = 0; r < single.rows(); ++r) {
      const Eigen::Index demo_end = (r / 40 + 1) * 40 - 1;
      for (Eigen::Index j = 0; j < 5; ++j)
        for (Eigen::Index d = 0; d < 2; ++d)
          EXPECT_EQ(chunks(r, 2 * j + d), single(std::min(r + j, demo_end), d)) << "row " << r << " step " << j;
    }
  }
  std::mt19937_64 ra(9), rb(9);
  const Batch ta = a.sample(6, ra, ag::Dtype::Float64), tb = b.sample(6, rb, ag::Dtype::Float64);
  EXPECT_EQ(ta.observations.to_vector(), tb.observations.to_vector());
  EXPECT_EQ(tb.actions.shape(), (ag::Shape{12, 10}));
  const auto first = ta.actions.matrix<double>(), chunks = tb.actions.matrix<double>();
  for (Eigen::Index r = 0; r < 12; ++r) EXPECT_EQ(chunks.row(r).head(2), first.row(r)) << "row " << r;
  DataConfig bad = one;
  bad.action_horizon = 0;
  EXPECT_THAT([&] { DemoDataset(file, bad); },
              ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("action horizon must be 1 to 1000, got 0")));
}

TEST(DemoDataset, BadRequestsAreNamed) {
  const envs::DemoFile file = synthetic_demo_file();
  DataConfig config;
  config.demos_per_task = 5;
  EXPECT_THAT([&] { DemoDataset(file, config); },
              ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("synthetic/a has 4 training demos")));
  config.demos_per_task = 1;
  config.subsample = 0;
  EXPECT_THAT([&] { DemoDataset(file, config); },
              ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("subsample")));
}

TEST(DemoDataset, ObservationClipClampsEveryStandardisedInputAndRejectsBadBounds) {
  const envs::DemoFile file = synthetic_demo_file();
  DataConfig config;
  const DemoDataset open(file, config);
  EXPECT_EQ(open.standardizer().clip, 0.0);
  config.observation_clip = 0.5;
  const DemoDataset clipped(file, config);
  EXPECT_EQ(clipped.standardizer().clip, 0.5);
  EXPECT_EQ(clipped.standardizer().mean, open.standardizer().mean);  // the statistics are the same
  std::mt19937_64 r1(4), r2(4);
  const Batch a = open.sample(64, r1, ag::Dtype::Float64), b = clipped.sample(64, r2, ag::Dtype::Float64);
  const Eigen::MatrixXd raw = a.observations.matrix<double>();
  ASSERT_GT(raw.cwiseAbs().maxCoeff(), 0.5);  // the batch has inputs the clamp changes
  EXPECT_EQ(Eigen::MatrixXd(b.observations.matrix<double>()), Eigen::MatrixXd(raw.cwiseMax(-0.5).cwiseMin(0.5)));
  EXPECT_LE(b.previous_observations.matrix<double>().cwiseAbs().maxCoeff(), 0.5);
  // A single observation (rollouts, evaluation) is clamped alike.
  const Eigen::VectorXd far = open.standardizer().mean + 100.0 * open.standardizer().std;
  EXPECT_EQ(clipped.standardizer().apply(far), Eigen::VectorXd::Constant(far.size(), 0.5));
  EXPECT_NEAR(open.standardizer().apply(far).minCoeff(), 100.0, 1e-9);
  // Transfer's statistics from another run keep this run's clamp.
  DemoDataset replaced(file, config);
  Standardizer other = open.standardizer();
  other.clip = 7.0;
  replaced.use_standardizer(other);
  EXPECT_EQ(replaced.standardizer().clip, 0.5);
  for (double bad : {-1.0, std::nan(""), std::numeric_limits<double>::infinity()}) {
    config.observation_clip = bad;
    EXPECT_THAT([&] { DemoDataset(file, config); },
                ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("observation_clip must be finite and >= 0")));
  }
}

// 3 of the 6 training demos of synthetic_demo_file(9)'s tasks, every 5th state.
DataConfig three_demos_every_fifth_state() {
  DataConfig config;
  config.demos_per_task = 3;
  config.subsample = 5;
  config.seed = 11;
  return config;
}

TEST(DemoDataset, KeptTasksDrawTheSameDemosWhateverElseIsKept) {
  const envs::DemoFile file = synthetic_demo_file(9);  // 6 train, 3 valid per task
  DataConfig all = three_demos_every_fifth_state();
  all.task_demos = {{"synthetic/b", 2}};
  const DemoDataset full(file, all);
  DataConfig only_b = all, without_b = all;
  only_b.tasks = {"synthetic/b"};
  without_b.holdout = {"synthetic/b"};
  const DemoDataset b(file, only_b), a(file, without_b);
  ASSERT_EQ(b.task_names(), std::vector<std::string>{"synthetic/b"});
  ASSERT_EQ(a.task_names(), std::vector<std::string>{"synthetic/a"});
  EXPECT_EQ(b.training_demo_seeds()[0], full.training_demo_seeds()[1]);  // the same demos and offsets
  EXPECT_EQ(b.training_samples(0), full.training_samples(1));
  EXPECT_EQ(b.training_demo_seeds()[0].size(), 2u);  // task_demos
  EXPECT_EQ(a.training_demo_seeds()[0], full.training_demo_seeds()[0]);
  EXPECT_EQ(a.training_demo_seeds()[0].size(), 3u);
  EXPECT_DOUBLE_EQ(b.demo_mean_return(0), 80.0);
  std::mt19937_64 rng(0);
  const Batch batch = b.sample(4, rng, ag::Dtype::Float64);
  EXPECT_EQ(batch.tasks, std::vector<std::int64_t>(4, 0));  // task ids among the kept tasks
}

TEST(DemoDataset, PerTaskDrawsDependOnTheTasksOwnCountOnly) {
  const envs::DemoFile file = synthetic_demo_file(9);
  DataConfig base = three_demos_every_fifth_state();
  DataConfig fewer_a = base;
  fewer_a.task_demos = {{"synthetic/a", 1}};  // the task before b in the file draws less
  // One stream through the tasks: b's demos or offsets move with a's count.
  const DemoDataset seq(file, base), seq_fewer(file, fewer_a);
  bool moved = seq.training_demo_seeds()[1] != seq_fewer.training_demo_seeds()[1];
  std::mt19937_64 r1(5), r2(5);
  moved = moved || seq.task_training_batch(1, 64, r1, ag::Dtype::Float64).observations.to_vector() !=
                       seq_fewer.task_training_batch(1, 64, r2, ag::Dtype::Float64).observations.to_vector();
  EXPECT_TRUE(moved) << "the sequential draw of b no longer depends on a's count: the test lost its point";
  // A stream per task: b's demos and offsets (its raw training states) are the same whatever a's count.
  base.draws = fewer_a.draws = "per_task";
  const DemoDataset per(file, base), per_fewer(file, fewer_a);
  EXPECT_EQ(per.training_demo_seeds()[1], per_fewer.training_demo_seeds()[1]);
  EXPECT_EQ(per_fewer.training_demo_seeds()[0].size(), 1u);
  const auto raw_states = [](const DemoDataset& data, int task) {
    std::mt19937_64 rng(5);
    const Batch batch = data.task_training_batch(task, 64, rng, ag::Dtype::Float64);
    Eigen::MatrixXd m = batch.observations.matrix<double>();
    for (Eigen::Index j = 0; j < m.cols(); ++j)  // undo the standardisation, which a's states change
      m.col(j) = m.col(j).array() * data.standardizer().std[j] + data.standardizer().mean[j];
    return m;
  };
  EXPECT_TRUE(raw_states(per, 1).isApprox(raw_states(per_fewer, 1), 1e-12));
  // A's first demo under both counts: nested draws (the fewer are the first of the shuffle).
  DataConfig one_a = base;
  one_a.task_demos = {{"synthetic/a", 1}};
  const auto& three = per.training_demo_seeds()[0];
  const std::uint64_t first = DemoDataset(file, one_a).training_demo_seeds()[0][0];
  EXPECT_NE(std::find(three.begin(), three.end(), first), three.end());
  base.draws = "by_name";
  EXPECT_THAT([&] { DemoDataset(file, base); },
              ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("data.draws: expected")));
}

TEST(DemoDataset, ValidationBatchOfChosenTasks) {
  const envs::DemoFile file = synthetic_demo_file();
  const DemoDataset data(file, DataConfig{});
  const Batch all = data.validation_batch(ag::Dtype::Float64, 7);
  const Batch b = data.validation_batch(ag::Dtype::Float64, 7, {"synthetic/b"});
  ASSERT_EQ(b.size(), 7);
  EXPECT_EQ(b.tasks, std::vector<std::int64_t>(7, 1));
  const ag::RowMatrixD b_rows = ag::to_eigen_double(b.observations), all_rows = ag::to_eigen_double(all.observations);
  EXPECT_EQ(b_rows, all_rows.middleRows(7, 7)) << "not b's rows of the all-task batch";
  EXPECT_THAT([&] { data.validation_batch(ag::Dtype::Float64, 7, {"synthetic/c"}); },
              ::testing::ThrowsMessage<std::invalid_argument>(
                  HasSubstr("train.validation_tasks: 'synthetic/c' is not a task of this run")));
}

TEST(DemoDataset, UnknownOrNoTasksAreNamed) {
  const envs::DemoFile file = synthetic_demo_file();
  DataConfig config;
  config.holdout = {"synthetic/c"};
  EXPECT_THAT([&] { DemoDataset(file, config); },
              ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("data.holdout: 'synthetic/c' is not a task")));
  config.holdout = {"synthetic/a", "synthetic/b"};
  EXPECT_THAT([&] { DemoDataset(file, config); },
              ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("leave no task")));
  config.holdout = {};
  config.task_demos = {{"synthetic/a", 9}};
  EXPECT_THAT([&] { DemoDataset(file, config); }, ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr(
                                                      "synthetic/a has 4 training demos (mask/train), 9 requested")));
}

}  // namespace
}  // namespace maps::core
