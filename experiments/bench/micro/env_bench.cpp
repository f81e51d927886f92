// Env steps per second: HalfCheetahEnv::step against bare mj_step x5 on the same compiled model,
// same initial state and same action sequence, in the same run. The wrapper's work beyond
// physics (checks, clipping, observation and reward, the time limit) should cost under 5%.
//
//   maps_bench --benchmark_filter=Cheetah
//
// BM_CheetahWrapperOverhead alternates blocks of the two loops in one benchmark and reports the
// overhead in percent, which cancels slow drifts of the clock between separate benchmarks.
#include <benchmark/benchmark.h>
#include <mujoco/mujoco.h>

#include <Eigen/Core>
#include <chrono>
#include <cmath>
#include <vector>

#include "envs/half_cheetah.h"

namespace {

using maps::envs::HalfCheetahEnv;
using maps::envs::MjDataPtr;

constexpr int kHorizon = HalfCheetahEnv::kHorizon;
constexpr std::uint64_t kSeed = 0;

// One episode of varied actions (some out of range, as a Gaussian policy gives).
std::vector<Eigen::VectorXd> action_table() {
  std::vector<Eigen::VectorXd> actions(kHorizon, Eigen::VectorXd(6));
  for (int t = 0; t < kHorizon; ++t) {
    for (int j = 0; j < 6; ++j) actions[static_cast<std::size_t>(t)][j] = 1.2 * std::sin(0.37 * t + 1.1 * j);
  }
  return actions;
}

// The wrapper: reset at the time limit, like a rollout loop does.
struct WrapperLoop {
  HalfCheetahEnv env{"gravity/1.0", 2};
  const std::vector<Eigen::VectorXd>& actions;
  int t = 0;
  explicit WrapperLoop(const std::vector<Eigen::VectorXd>& a) : actions(a) { env.reset(kSeed); }
  double step() {
    const maps::envs::StepResult r = env.step(actions[static_cast<std::size_t>(t)]);
    if (++t == kHorizon) {
      env.reset(kSeed);
      t = 0;
    }
    return r.reward;
  }
};

// Bare MuJoCo on the env's own model: same initial state, clipped ctrl, 5 x mj_step, x position.
struct BareLoop {
  const mjModel* model;
  MjDataPtr data;
  Eigen::VectorXd qpos0, qvel0;
  const std::vector<Eigen::VectorXd>& actions;
  int t = 0;
  BareLoop(const HalfCheetahEnv& env, const std::vector<Eigen::VectorXd>& a)
      : model(env.model()), data(mj_makeData(env.model())), actions(a) {
    HalfCheetahEnv initial("gravity/1.0", 2);
    initial.reset(kSeed);
    qpos0 = Eigen::Map<const Eigen::VectorXd>(initial.data()->qpos, model->nq);
    qvel0 = Eigen::Map<const Eigen::VectorXd>(initial.data()->qvel, model->nv);
    reset();
  }
  void reset() {
    mj_resetData(model, data.get());
    Eigen::Map<Eigen::VectorXd>(data->qpos, model->nq) = qpos0;
    Eigen::Map<Eigen::VectorXd>(data->qvel, model->nv) = qvel0;
    mj_forward(model, data.get());
  }
  double step() {
    const Eigen::VectorXd& a = actions[static_cast<std::size_t>(t)];
    for (int j = 0; j < model->nu; ++j) data->ctrl[j] = std::fmin(1.0, std::fmax(-1.0, a[j]));
    const double x_before = data->qpos[0];
    for (int k = 0; k < HalfCheetahEnv::kFrameSkip; ++k) mj_step(model, data.get());
    if (++t == kHorizon) {
      reset();
      t = 0;
    }
    return data->qpos[0] - x_before;
  }
};

void BM_CheetahEnvStep(benchmark::State& state) {
  const auto actions = action_table();
  WrapperLoop loop(actions);
  for (auto _ : state) benchmark::DoNotOptimize(loop.step());
  state.counters["env_steps_per_s"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_CheetahEnvStep);

void BM_CheetahBareMjStep(benchmark::State& state) {
  const auto actions = action_table();
  const HalfCheetahEnv env("gravity/1.0", 2);
  BareLoop loop(env, actions);
  for (auto _ : state) benchmark::DoNotOptimize(loop.step());
  state.counters["env_steps_per_s"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_CheetahBareMjStep);

// Alternating blocks of one episode each; the counters give both rates and the overhead.
void BM_CheetahWrapperOverhead(benchmark::State& state) {
  using Clock = std::chrono::steady_clock;
  const auto actions = action_table();
  WrapperLoop wrapper(actions);
  BareLoop bare(wrapper.env, actions);
  double wrapper_seconds = 0.0, bare_seconds = 0.0;
  std::int64_t blocks = 0;
  for (auto _ : state) {
    auto start = Clock::now();
    for (int t = 0; t < kHorizon; ++t) benchmark::DoNotOptimize(wrapper.step());
    auto middle = Clock::now();
    for (int t = 0; t < kHorizon; ++t) benchmark::DoNotOptimize(bare.step());
    auto end = Clock::now();
    wrapper_seconds += std::chrono::duration<double>(middle - start).count();
    bare_seconds += std::chrono::duration<double>(end - middle).count();
    ++blocks;
  }
  const double steps = static_cast<double>(blocks) * kHorizon;
  state.counters["wrapper_steps_per_s"] = steps / wrapper_seconds;
  state.counters["bare_steps_per_s"] = steps / bare_seconds;
  state.counters["overhead_pct"] = 100.0 * (wrapper_seconds / bare_seconds - 1.0);
}
BENCHMARK(BM_CheetahWrapperOverhead)->Unit(benchmark::kMillisecond)->MinTime(3.0);

}  // namespace
