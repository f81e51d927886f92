#include "maps/training/curve_cost.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "tests/common/scratch_path.h"

namespace maps::core {
namespace {

namespace fs = std::filesystem;

fs::path curve_file(const std::string& name, const std::string& text) {
  const fs::path path = scratch_path("maps_curve_cost_test_" + name);
  std::ofstream(path, std::ios::trunc) << text;
  return path;
}

constexpr const char* kCpuCurve =
    "step,bc,total,validation_bc,steps_per_second,cpu_seconds\n"
    "20,1,1,0.5,10,2.5\n"
    "40,1,1,0.4,10,3\n"
    "60,1,1,0.3,10,4\n";

TEST(CurveCost, SumsTheCpuColumnUpToTheStep) {
  const auto cost = curve_training_cost(curve_file("cpu", kCpuCurve).string(), 60);
  ASSERT_TRUE(cost.has_value());
  EXPECT_TRUE(cost->cpu);
  EXPECT_DOUBLE_EQ(cost->seconds, 9.5);
  // Rows past the step are another budget's (a run extended later).
  const auto first = curve_training_cost(curve_file("cpu", kCpuCurve).string(), 40);
  ASSERT_TRUE(first.has_value());
  EXPECT_DOUBLE_EQ(first->seconds, 5.5);
}

TEST(CurveCost, WithoutTheCpuColumnEachWindowIsItsStepsOverItsSpeed) {
  const auto cost = curve_training_cost(
      curve_file("speed", "step,bc,total,validation_bc,steps_per_second\n20,1,1,0.5,10\n50,1,1,0.4,15\n").string(), 50);
  ASSERT_TRUE(cost.has_value());
  EXPECT_FALSE(cost->cpu);
  EXPECT_DOUBLE_EQ(cost->seconds, 2.0 + 2.0);
}

TEST(CurveCost, ACurveWithWindowsLineEndingsReadsTheSame) {
  std::string crlf;
  for (const char c : std::string(kCpuCurve)) crlf += c == '\n' ? std::string("\r\n") : std::string(1, c);
  const auto cost = curve_training_cost(curve_file("crlf", crlf).string(), 60);
  ASSERT_TRUE(cost.has_value());
  EXPECT_DOUBLE_EQ(cost->seconds, 9.5);
}

TEST(CurveCost, ACurveThatCannotSayIsNoAnswer) {
  EXPECT_FALSE(curve_training_cost("/nonexistent/curve.csv", 60).has_value());
  EXPECT_FALSE(curve_training_cost(curve_file("empty", "").string(), 60).has_value());
  // Ends before the step (an unfinished run), or between two rows.
  EXPECT_FALSE(curve_training_cost(curve_file("short", kCpuCurve).string(), 80).has_value());
  EXPECT_FALSE(curve_training_cost(curve_file("between", kCpuCurve).string(), 50).has_value());
  const std::string header = "step,bc,total,validation_bc,steps_per_second,cpu_seconds\n";
  EXPECT_FALSE(curve_training_cost(curve_file("zero", header + "20,1,1,0.5,10,0\n").string(), 20).has_value());
  EXPECT_FALSE(curve_training_cost(curve_file("text", header + "20,1,1,0.5,10,x\n").string(), 20).has_value());
  EXPECT_FALSE(curve_training_cost(curve_file("cut", header + "20,1,1,0.5\n").string(), 20).has_value());
  EXPECT_FALSE(curve_training_cost(curve_file("no_time", "step,bc\n20,1\n").string(), 20).has_value());
}

constexpr const char* kGailCurve =
    "iteration,env_steps_per_task,return:a,return:b,env_steps_per_second\n"
    "1,2000,1,1,40\n"
    "2,4000,1,1,40\n"
    "3,6000,1,1,20\n";

TEST(GailCurveCost, EachIterationIsItsEnvStepsOverItsSpeed) {
  // Two tasks: 4,000 env steps an iteration, 100 + 100 + 200 s.
  const auto cost = gail_curve_training_cost(curve_file("gail", kGailCurve).string(), 6000, 2);
  ASSERT_TRUE(cost.has_value());
  EXPECT_DOUBLE_EQ(cost->seconds, 400.0);
  EXPECT_FALSE(cost->cpu);
  const auto first = gail_curve_training_cost(curve_file("gail", kGailCurve).string(), 4000, 2);
  ASSERT_TRUE(first.has_value());
  EXPECT_DOUBLE_EQ(first->seconds, 200.0);
}

TEST(GailCurveCost, AnIterationOfAStoppedProcessCostsTheMedian) {
  // 100, 100, 200 (shared cores: logged), 100 s, then one stopped for two hours (7,200 s logged): it counts at the
  // median, 100 s.
  const std::string curve = std::string(kGailCurve) + "4,8000,1,1,40\n" + "5,10000,1,1,0.5555555555555556\n";
  const auto cost = gail_curve_training_cost(curve_file("gail_stopped", curve).string(), 10000, 2);
  ASSERT_TRUE(cost.has_value());
  EXPECT_DOUBLE_EQ(cost->seconds, 600.0);
  EXPECT_DOUBLE_EQ(sum_without_stops({}), 0.0);
  EXPECT_DOUBLE_EQ(sum_without_stops({3.0}), 3.0);
  // The median of an even count is the mean of its middle two (20): 30 x 20 = 600 stays, 601 counts as 20.
  EXPECT_DOUBLE_EQ(sum_without_stops({10.0, 30.0, 600.0, 5.0}), 645.0);
  EXPECT_DOUBLE_EQ(sum_without_stops({10.0, 30.0, 601.0, 5.0}), 65.0);
}

TEST(GailCurveCost, ACurveWithCpuSecondsCostsTheirSum) {
  // The last iteration was stopped for hours by the wall clock (a speed of 0.5); its CPU time did not grow.
  const std::string curve =
      "iteration,env_steps_per_task,return:a,return:b,env_steps_per_second,cpu_seconds\n"
      "1,2000,1,1,40,90.5\n2,4000,1,1,40,101\n3,6000,1,1,0.5,99.25\n";
  const auto cost = gail_curve_training_cost(curve_file("gail_cpu", curve).string(), 6000, 2);
  ASSERT_TRUE(cost.has_value());
  EXPECT_DOUBLE_EQ(cost->seconds, 290.75);
  EXPECT_TRUE(cost->cpu);
}

TEST(GailCurveCost, ACurveThatCannotSayIsNoAnswer) {
  const std::string header = "iteration,env_steps_per_task,env_steps_per_second\n";
  EXPECT_FALSE(gail_curve_training_cost("/nonexistent/curve.csv", 2000, 2).has_value());
  EXPECT_FALSE(gail_curve_training_cost(curve_file("gail_short", kGailCurve).string(), 8000, 2).has_value());
  EXPECT_FALSE(gail_curve_training_cost(curve_file("gail_between", kGailCurve).string(), 5000, 2).has_value());
  EXPECT_FALSE(gail_curve_training_cost(curve_file("gail", kGailCurve).string(), 6000, 0).has_value());
  EXPECT_FALSE(gail_curve_training_cost(curve_file("gail_zero", header + "1,2000,0\n").string(), 2000, 2).has_value());
  EXPECT_FALSE(gail_curve_training_cost(curve_file("gail_back", header + "1,2000,40\n2,2000,40\n").string(), 2000, 2)
                   .has_value());
  EXPECT_FALSE(gail_curve_training_cost(curve_file("gail_nan", header + "1,2000,nan\n").string(), 2000, 2).has_value());
  // A BC run's curve has no env steps.
  EXPECT_FALSE(gail_curve_training_cost(curve_file("bc", kCpuCurve).string(), 60, 2).has_value());
}

}  // namespace
}  // namespace maps::core
