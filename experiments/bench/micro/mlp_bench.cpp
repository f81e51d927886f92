// Forward, backward and Adam of a 3x128 tanh MLP at batch 640, against Eigen's float32 GEMM timed
// in the same run. Run: build/bin/maps_bench --benchmark_filter='Mlp|Gemm'
#include <benchmark/benchmark.h>

#include <chrono>
#include <vector>

#include "autograd/autograd.h"
#include "nn/nn.h"

namespace {

using namespace maps;

constexpr std::int64_t kBatch = 640;
// HalfCheetah-shaped: 17 observations in, three hidden layers of 128, 6 actions out.
const std::vector<std::int64_t> kSizes = {17, 128, 128, 128, 6};

double forward_flops() {
  double flops = 0;
  for (std::size_t i = 0; i + 1 < kSizes.size(); ++i) flops += 2.0 * kBatch * kSizes[i] * kSizes[i + 1];
  return flops;
}

// Backward computes dW for every layer and dX for all but the first (the input needs no gradient).
double backward_flops() {
  double flops = 0;
  for (std::size_t i = 0; i + 1 < kSizes.size(); ++i) {
    flops += 2.0 * kBatch * kSizes[i] * kSizes[i + 1] * (i == 0 ? 1 : 2);
  }
  return flops;
}

// Eigen float32 GEMM C = A B in GFLOP/s, timed for about `seconds`.
double gemm_gflops(std::int64_t n, std::int64_t k, std::int64_t m, double seconds = 0.3) {
  Eigen::MatrixXf a = Eigen::MatrixXf::Random(n, k), b = Eigen::MatrixXf::Random(k, m), c(n, m);
  std::int64_t reps = 0;
  const auto start = std::chrono::steady_clock::now();
  double elapsed = 0;
  do {
    c.noalias() = a * b;
    benchmark::DoNotOptimize(c.data());
    ++reps;
    elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  } while (elapsed < seconds);
  return 2.0 * n * k * m * reps / elapsed * 1e-9;
}

// Both references are timed once per process, in the same run as the MLP.
double same_shape_gemm() {
  static const double g = gemm_gflops(kBatch, 128, 128);
  return g;
}
double large_gemm() {
  static const double g = gemm_gflops(1024, 1024, 1024, 1.0);
  return g;
}

struct Fixture {
  ag::Generator gen{0};
  std::shared_ptr<nn::MLP> mlp = std::make_shared<nn::MLP>(kSizes, "tanh", gen);
  ag::Tensor x = ag::randn({kBatch, kSizes.front()}, gen);
  ag::Tensor y = ag::randn({kBatch, kSizes.back()}, gen);
};

template <typename Body>
void run(benchmark::State& state, double flops_per_iteration, Body body) {
  std::int64_t iterations = 0;
  const auto start = std::chrono::steady_clock::now();
  for (auto _ : state) {
    body();
    ++iterations;
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const double gflops = flops_per_iteration * iterations / seconds * 1e-9;
  state.counters["GFLOP/s"] = gflops;
  state.counters["vs_gemm_same_shape"] = gflops / same_shape_gemm();
  state.counters["vs_gemm_1024"] = gflops / large_gemm();
}

void BM_EigenGemm_640x128x128(benchmark::State& state) {
  Eigen::MatrixXf a = Eigen::MatrixXf::Random(kBatch, 128), b = Eigen::MatrixXf::Random(128, 128), c(kBatch, 128);
  run(state, 2.0 * kBatch * 128 * 128, [&] {
    c.noalias() = a * b;
    benchmark::DoNotOptimize(c.data());
  });
}

void BM_EigenGemm_1024(benchmark::State& state) {
  Eigen::MatrixXf a = Eigen::MatrixXf::Random(1024, 1024), b = Eigen::MatrixXf::Random(1024, 1024), c(1024, 1024);
  run(state, 2.0 * 1024 * 1024 * 1024, [&] {
    c.noalias() = a * b;
    benchmark::DoNotOptimize(c.data());
  });
}

void BM_MlpForward(benchmark::State& state) {
  Fixture f;
  ag::NoGradGuard no_grad;
  run(state, forward_flops(), [&] { benchmark::DoNotOptimize(f.mlp->forward(f.x).impl().get()); });
}

void BM_MlpForwardBackward(benchmark::State& state) {
  Fixture f;
  run(state, forward_flops() + backward_flops(), [&] {
    f.mlp->zero_grad();
    ag::mse_loss(f.mlp->forward(f.x), f.y).backward();
  });
}

void BM_MlpAdamStep(benchmark::State& state) {
  Fixture f;
  ag::Tensor loss = ag::mse_loss(f.mlp->forward(f.x), f.y);
  loss.backward();
  optim::Adam adam(f.mlp->parameters(), {.lr = 1e-4});
  const double parameters = static_cast<double>(f.mlp->parameter_count());
  // Adam is elementwise (about 12 flops per parameter); reported for scale, not against GEMM.
  run(state, 12.0 * parameters, [&] { adam.step(); });
}

void BM_MlpTrainStep(benchmark::State& state) {
  Fixture f;
  optim::Adam adam(f.mlp->parameters(), {.lr = 1e-4});
  run(state, forward_flops() + backward_flops(), [&] {
    adam.zero_grad();
    ag::mse_loss(f.mlp->forward(f.x), f.y).backward();
    adam.step();
  });
}

BENCHMARK(BM_EigenGemm_640x128x128)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_EigenGemm_1024)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_MlpForward)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_MlpForwardBackward)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_MlpAdamStep)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_MlpTrainStep)->Unit(benchmark::kMicrosecond);

}  // namespace
