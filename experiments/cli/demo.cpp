// `maps demo`: a tanh MLP (nn::MLP) fitted to a synthetic regression with optim::Adam.

#include <Eigen/Core>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <vector>

#include "autograd/autograd.h"
#include "experiments/cli/command.h"
#include "experiments/cli/options.h"
#include "nn/nn.h"

namespace maps::experiments::cli {
namespace {

struct DemoOptions {
  int steps = 500;         // optimiser steps (full batch)
  std::uint64_t seed = 0;  // seeds the data and the initial weights
  int hidden = 32;         // hidden width of the 2-layer MLP
  double lr = 0.01;        // Adam learning rate
  int log_every = 50;      // print the loss every this many steps
  int samples = 256;       // size of the synthetic data set
};

namespace ag = maps::ag;

constexpr std::int64_t kInputs = 3;
constexpr std::int64_t kOutputs = 1;

// The function to learn: y = sin(2 x0) + 0.5 x1 x2 - 0.3 x2^2, for x uniform in [-2, 2)^3.
ag::Tensor make_targets(const ag::Tensor& x) {
  const auto xs = x.matrix<float>();
  ag::RowMatrixF y(xs.rows(), kOutputs);
  for (Eigen::Index i = 0; i < xs.rows(); ++i) {
    y(i, 0) = std::sin(2.0f * xs(i, 0)) + 0.5f * xs(i, 1) * xs(i, 2) - 0.3f * xs(i, 2) * xs(i, 2);
  }
  return ag::from_eigen(y);
}

// Returns 0 when the final loss is below the initial loss, 1 otherwise.
int run_demo(const DemoOptions& options) {
  ag::Generator gen(options.seed);
  const std::int64_t n = options.samples;
  const std::int64_t hidden = options.hidden;

  const ag::Tensor x = ag::rand({n, kInputs}, gen, ag::Dtype::Float32, -2.0, 2.0);
  const ag::Tensor y = make_targets(x);

  nn::MLP mlp({kInputs, hidden, kOutputs}, "tanh", gen);
  auto loss_of = [&]() { return ag::mse_loss(mlp.forward(x), y); };

  std::printf("maps demo: tanh MLP %lld -> %lld -> %lld, %lld samples, Adam lr %g, %d steps, seed %llu\n",
              static_cast<long long>(kInputs), static_cast<long long>(hidden), static_cast<long long>(kOutputs),
              static_cast<long long>(n), options.lr, options.steps, static_cast<unsigned long long>(options.seed));

  optim::Adam adam(mlp.parameters(), {.lr = options.lr});
  double first_loss = 0.0;
  const auto start = std::chrono::steady_clock::now();
  for (int step = 0; step < options.steps; ++step) {
    const ag::Tensor loss = loss_of();
    const double value = loss.item();
    if (step == 0) first_loss = value;
    if (!std::isfinite(value)) {
      std::printf("step %6d  loss %g: not finite, stopping\n", step, value);
      return 1;
    }
    if (step % options.log_every == 0) std::printf("step %6d  loss %.6f\n", step, value);
    adam.zero_grad();
    loss.backward();
    adam.step();
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  double final_loss = 0.0;
  {
    ag::NoGradGuard no_grad;
    final_loss = loss_of().item();
  }
  std::printf("step %6d  loss %.6f\n", options.steps, final_loss);
  std::printf("%.3f s, %.0f steps/s\n", seconds, options.steps / (seconds > 0.0 ? seconds : 1e-9));

  if (std::isfinite(final_loss) && final_loss < first_loss) {
    std::printf("loss fell from %.6f to %.6f\n", first_loss, final_loss);
    return 0;
  }
  std::printf("loss did not fall: from %.6f to %.6f\n", first_loss, final_loss);
  return 1;
}

}  // namespace

void add_demo(CLI::App& tool, Commands& commands) {
  auto options = std::make_shared<DemoOptions>();
  CLI::App* command =
      tool.add_subcommand("demo", "Train a small tanh MLP on a synthetic regression and print the loss falling");
  add_positive(command, "--steps", options->steps, "Optimiser steps");
  add_seed(command, options->seed, "Seed of the data and the initial weights");
  command->add_option("--hidden", options->hidden, "Hidden width")->check(number_in(1, 65536))->capture_default_str();
  add_positive(command, "--lr", options->lr, "Adam learning rate");
  add_positive(command, "--log-every", options->log_every, "Print the loss every N steps");
  commands.push_back({command, [options] { return run_demo(*options); }});
}

}  // namespace maps::experiments::cli
