#include "optim_test_util.h"

namespace nntest {
namespace {

// Reference values from PyTorch 1.13, with run() as in adam_test.cpp:
//   print(run(torch.optim.SGD, torch.float64, lr=0.1))
//   print(run(torch.optim.SGD, torch.float64, lr=0.1, momentum=0.9, dampening=0.1, weight_decay=0.01))
//   print(run(torch.optim.SGD, torch.float64, lr=0.1, momentum=0.9, nesterov=True, weight_decay=0.01))

TEST(SGD, PlainMatchesPyTorch) {
  const std::vector<double> expected = {
      0.35, -0.8999999999999999, 1.9315, 0.275, 1.4960000000000004, 0.9500000000000001, -0.04999999999999999};
  const auto got = run_reference_problem(
      Dtype::Float64, [](std::vector<Tensor> params) { return optim::SGD(std::move(params), {.lr = 0.1}); });
  expect_all_near(got, expected, 1e-12);
}

TEST(SGD, MomentumDampeningWeightDecayMatchesPyTorch) {
  const std::vector<double> expected = {0.2048960717486673,  -0.7435362497502127, 1.7642901722571251,
                                        0.44100580465817935, 1.4788100241368223,  1.716067305013418,
                                        -0.9515550618131533};
  const auto got = run_reference_problem(Dtype::Float64, [](std::vector<Tensor> params) {
    return optim::SGD(std::move(params), {.lr = 0.1, .momentum = 0.9, .dampening = 0.1, .weight_decay = 0.01});
  });
  expect_all_near(got, expected, 1e-12);
}

TEST(SGD, NesterovMatchesPyTorch) {
  const std::vector<double> expected = {0.057493468707169315, -0.6480130324996967, 1.6998276143902233,
                                        0.7130547807374241,   1.4697254602618302,  2.878796929400607,
                                        -1.681045540975031};
  const auto got = run_reference_problem(Dtype::Float64, [](std::vector<Tensor> params) {
    return optim::SGD(std::move(params), {.lr = 0.1, .momentum = 0.9, .weight_decay = 0.01, .nesterov = true});
  });
  expect_all_near(got, expected, 1e-12);
}

TEST(SGD, Float32AndOptionChecks) {
  const std::vector<double> expected = {0.35, -0.9, 1.9315, 0.275, 1.496, 0.95, -0.05};
  const auto got = run_reference_problem(
      Dtype::Float32, [](std::vector<Tensor> params) { return optim::SGD(std::move(params), {.lr = 0.1}); });
  expect_all_near(got, expected, 1e-6);
  Tensor p = ag::ones({1}).requires_grad_();
  EXPECT_THAT(error_of([&] { optim::SGD({p}, {.lr = -0.1}); }), HasSubstr("invalid learning rate"));
  EXPECT_THAT(error_of([&] { optim::SGD({p}, {.lr = 0.1, .momentum = -1.0}); }), HasSubstr("invalid momentum"));
  EXPECT_THAT(error_of([&] { optim::SGD({p}, {.lr = 0.1, .nesterov = true}); }), HasSubstr("nesterov"));
  optim::SGD sgd({p}, {.lr = 0.1});
  sgd.set_lr(0.01);
  EXPECT_EQ(sgd.lr(), 0.01);
}

}  // namespace
}  // namespace nntest
