// Executing action chunks (maps/chunking, issue 46): ACT's temporal ensemble by hand (weights exp(-m i), i = 0 the
// oldest chunk covering the step, normalised), chunks that end dropping out, open-loop execution of the first
// `execute` actions, and refusals.

#include "maps/chunking/temporal_ensemble.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>

#include "tests/common/error_of.h"

namespace {

using maps::chunking::OpenLoop;
using maps::chunking::TemporalEnsemble;
using ::testing::HasSubstr;

// A chunk of `rows` one-dimensional actions, value base + row.
Eigen::MatrixXd chunk(int rows, double base) {
  Eigen::MatrixXd c(rows, 1);
  for (int r = 0; r < rows; ++r) c(r, 0) = base + r;
  return c;
}

TEST(TemporalEnsemble, WeightsTheOldestChunkMostByHand) {
  TemporalEnsemble ensemble(0.5);
  ensemble.add(0, chunk(3, 0.0));  // votes 0, 1, 2 for steps 0-2
  EXPECT_NEAR(ensemble.action(0)(0), 0.0, 1e-15);
  ensemble.add(1, chunk(3, 10.0));  // votes 10, 11, 12 for steps 1-3
  // Step 1: the first chunk votes 1 (weight 1), the second 10 (weight e^-0.5).
  const double w = std::exp(-0.5);
  EXPECT_NEAR(ensemble.action(1)(0), (1.0 + w * 10.0) / (1.0 + w), 1e-12);
  ensemble.add(2, chunk(3, 20.0));
  // Step 2: three votes, 2, 11 and 20, weighted 1, e^-0.5, e^-1.
  EXPECT_NEAR(ensemble.action(2)(0), (2.0 + w * 11.0 + w * w * 20.0) / (1.0 + w + w * w), 1e-12);
  // Step 3: the first chunk has ended; the second is now the oldest (weight 1).
  EXPECT_NEAR(ensemble.action(3)(0), (12.0 + w * 21.0) / (1.0 + w), 1e-12);
  // With m = 0 it is the plain mean.
  TemporalEnsemble mean(0.0);
  mean.add(0, chunk(2, 0.0));
  mean.add(1, chunk(2, 4.0));
  EXPECT_NEAR(mean.action(1)(0), 2.5, 1e-15);
}

TEST(TemporalEnsemble, Refusals) {
  TemporalEnsemble ensemble;
  EXPECT_THAT(error_of([&] { ensemble.action(0); }), HasSubstr("no chunk covers step 0"));
  ensemble.add(3, chunk(2, 0.0));
  EXPECT_THAT(error_of([&] { ensemble.add(3, chunk(2, 0.0)); }), HasSubstr("steps must grow"));
  EXPECT_THAT(error_of([&] { ensemble.action(5); }), HasSubstr("no chunk covers step 5"));
  EXPECT_THAT(error_of([] { TemporalEnsemble(-1.0); }), HasSubstr("must be finite and >= 0"));
}

TEST(OpenLoop, ExecutesTheFirstActionsOfEachChunk) {
  OpenLoop loop(2);
  EXPECT_TRUE(loop.needs_chunk());
  loop.add(chunk(4, 0.0));
  EXPECT_FALSE(loop.needs_chunk());
  EXPECT_EQ(loop.action()(0), 0.0);
  EXPECT_EQ(loop.action()(0), 1.0);
  EXPECT_TRUE(loop.needs_chunk());
  EXPECT_THAT(error_of([&] { loop.action(); }), HasSubstr("the chunk is spent"));
  // A chunk shorter than `execute` is executed whole.
  OpenLoop long_execute(8);
  long_execute.add(chunk(3, 5.0));
  for (double expected : {5.0, 6.0, 7.0}) EXPECT_EQ(long_execute.action()(0), expected);
  EXPECT_TRUE(long_execute.needs_chunk());
  EXPECT_THAT(error_of([] { OpenLoop(0); }), HasSubstr("at least one action"));
}

}  // namespace
