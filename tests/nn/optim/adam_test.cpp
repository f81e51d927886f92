#include <cmath>

#include "optim_test_util.h"

namespace nntest {
namespace {

// Reference values from PyTorch 1.13 (Debian's python3-torch), produced by:
//
//   import torch
//   def run(opt_cls, dtype, **kw):
//       p = torch.tensor([[0.5, -1.0], [2.0, 0.0]], dtype=dtype, requires_grad=True)
//       q = torch.tensor([1.5, -0.25, 0.75], dtype=dtype, requires_grad=True)
//       opt = opt_cls([p, q], **kw)
//       for t in range(1, 6):
//           p.grad = torch.tensor([[0.1 * t, -0.2], [0.3 / t, -0.05 * t * t]], dtype=dtype)
//           q.grad = None if t == 3 else torch.tensor([0.01, -1.0 * t, 2.0], dtype=dtype)
//           opt.step()
//       return [repr(x) for x in p.detach().flatten().tolist() + q.detach().tolist()]
//   print(run(torch.optim.Adam, torch.float64, lr=0.01, betas=(0.8, 0.99), eps=1e-6, weight_decay=0.1))
//   print(run(torch.optim.Adam, torch.float32))

TEST(Adam, MatchesPyTorchWithWeightDecayAndEpsFloat64) {
  const std::vector<double> expected = {0.4494197677506977,  -0.9500296574133197, 1.9527142790834409,
                                        0.04741393911120505, 1.460029418227668,   -0.21057548973886328,
                                        0.7100022225302908};
  const auto got = run_reference_problem(Dtype::Float64, [](std::vector<Tensor> params) {
    return maps::optim::Adam(std::move(params),
                             {.lr = 0.01, .beta1 = 0.8, .beta2 = 0.99, .eps = 1e-6, .weight_decay = 0.1});
  });
  expect_all_near(got, expected, 1e-12);
}

TEST(Adam, MatchesPyTorchDefaultsFloat32) {
  const std::vector<double> expected = {0.4951491951942444,   -0.9950000643730164, 1.9955984354019165,
                                        0.004493376240134239, 1.495999813079834,   -0.24617484211921692,
                                        0.7460000514984131};
  const auto got = run_reference_problem(
      Dtype::Float32, [](std::vector<Tensor> params) { return maps::optim::Adam(std::move(params)); });
  expect_all_near(got, expected, 1e-6);
}

// Float32 against PyTorch 1.13's single-tensor Adam (foreach=False). The Release build (-O3)
// matches these bit for bit; the -O2 sanitizer build differs by up to 4e-7 (the compiler contracts
// the update's multiply-adds differently), so the test holds the bound of 1e-6. From:
//
//   import torch
//   p = torch.tensor([0.5, -1.25, 3.0, 1e-3, -7.0, 0.1], dtype=torch.float32, requires_grad=True)
//   opt = torch.optim.Adam([p], lr=0.01, betas=(0.8, 0.95), eps=1e-5, weight_decay=0.1, foreach=False)
//   for g in [[0.1, -0.2, 0.3, 1e-4, 5., -0.01], [0.3, 0.1, -0.3, 2e-4, -5., 0.02], [-0.1, 0.25, 0., 0., 1., 0.5],
//             [1., 1., 1., 1., 1., 1.], [0.01, -0.02, 0.03, 0.04, 0.05, 0.06]]:
//       p.grad = torch.tensor(g, dtype=torch.float32); opt.step()
//   print(" ".join("%.9g" % v for v in p.detach().tolist()))
TEST(Adam, MatchesPyTorchInFloat32WithWeightDecay) {
  Tensor p = ag::from_vector(std::vector<float>{0.5f, -1.25f, 3.0f, 1e-3f, -7.0f, 0.1f}, {6});
  p.requires_grad_();
  maps::optim::Adam adam({p}, {.lr = 0.01, .beta1 = 0.8, .beta2 = 0.95, .eps = 1e-5, .weight_decay = 0.1});
  const std::vector<std::vector<float>> grads = {{0.1f, -0.2f, 0.3f, 1e-4f, 5.f, -0.01f},
                                                 {0.3f, 0.1f, -0.3f, 2e-4f, -5.f, 0.02f},
                                                 {-0.1f, 0.25f, 0.f, 0.f, 1.f, 0.5f},
                                                 {1.f, 1.f, 1.f, 1.f, 1.f, 1.f},
                                                 {0.01f, -0.02f, 0.03f, 0.04f, 0.05f, 0.06f}};
  for (const auto& g : grads) {
    p.set_grad(ag::from_vector(g, {6}));
    adam.step();
  }
  const std::vector<float> expected = {0.460249841f,    -1.23992348f, 2.96006846f,
                                       -0.00853041001f, -7.00380659f, 0.0696757883f};
  for (int i = 0; i < 6; ++i) EXPECT_NEAR(p.data<float>()[i], expected[i], 1e-6) << "element " << i;
}

// A step changes the parameters in place: a graph kept from before it (retain_graph) must not be reused.
TEST(Adam, AStepMakesAGraphThatSavedTheOldParametersRefuseBackward) {
  Tensor p = ag::from_vector(std::vector<double>{0.5, -0.5}, {2}).requires_grad_();
  const Tensor loss = ag::sum(p * p);
  loss.backward(Tensor(), /*retain_graph=*/true);
  maps::optim::Adam adam({p});
  adam.step();
  EXPECT_THAT(error_of([&] { loss.backward(); }), HasSubstr("changed in place"));
}

TEST(Adam, SkipsParametersWithoutGrad) {
  Tensor p = ag::ones({2}).requires_grad_(), q = ag::ones({2}).requires_grad_();
  maps::optim::Adam adam({p, q});
  p.set_grad(ag::ones({2}));
  adam.step();
  EXPECT_EQ(adam.step_count(0), 1);
  EXPECT_EQ(adam.step_count(1), 0);
  EXPECT_EQ(q.to_vector(), (std::vector<double>{1.0, 1.0}));
  EXPECT_NEAR(p.at(0), 1.0 - 1e-3, 1e-7);  // the first Adam step moves by lr * sign(g)
  adam.zero_grad();
  EXPECT_FALSE(p.grad().defined());
}

TEST(Adam, RejectsInvalidOptions) {
  Tensor p = ag::ones({1}).requires_grad_();
  EXPECT_THAT(error_of([&] { maps::optim::Adam({p}, {.lr = -1.0}); }), HasSubstr("invalid learning rate"));
  EXPECT_THAT(error_of([&] { maps::optim::Adam({p}, {.beta1 = 1.0}); }), HasSubstr("invalid beta1"));
  EXPECT_THAT(error_of([&] { maps::optim::Adam({p}, {.beta2 = -0.1}); }), HasSubstr("invalid beta2"));
  EXPECT_THAT(error_of([&] { maps::optim::Adam({p}, {.eps = -1e-8}); }), HasSubstr("invalid epsilon"));
  EXPECT_THAT(error_of([&] { maps::optim::Adam({p}, {.weight_decay = -1.0}); }), HasSubstr("invalid weight_decay"));
  maps::optim::Adam adam({p});
  adam.set_lr(0.5);
  EXPECT_EQ(adam.lr(), 0.5);
  EXPECT_THAT(error_of([&] { adam.set_lr(-0.5); }), HasSubstr("invalid learning rate"));
  EXPECT_EQ(adam.lr(), 0.5);
}

TEST(Adam, RejectsBadParameters) {
  Tensor p = ag::ones({2}).requires_grad_();
  EXPECT_THAT(error_of([&] { maps::optim::Adam({p * 2.0}); }), HasSubstr("not a leaf"));
  EXPECT_THAT(error_of([&] { maps::optim::Adam({p, p}); }), HasSubstr("same tensor"));
}

TEST(Adam, StepRecordsNoGraph) {
  ag::Generator gen(71);
  nn::Linear lin(3, 2, gen);
  maps::optim::Adam adam(lin.parameters());
  ag::sum(lin.forward(ag::ones({4, 3}))).backward();
  adam.step();
  for (const auto& p : lin.parameters()) {
    EXPECT_TRUE(p.is_leaf());
    EXPECT_TRUE(p.requires_grad());
  }
}

TEST(Adam, StateRoundTripResumesExactly) {
  // Two parameters; the second gets no grad on the first step, so its step count lags.
  const auto make_params = [] {
    return std::vector<ag::Tensor>{ag::from_vector(std::vector<double>{1.0, -2.0, 0.5}, {3}, ag::Dtype::Float64),
                                   ag::from_vector(std::vector<double>{0.3, 0.7}, {2}, ag::Dtype::Float64)};
  };
  const auto set_grads = [](std::vector<ag::Tensor>& p, int step) {
    p[0].set_grad(ag::from_vector(std::vector<double>{0.1 * step, -0.2, 0.3}, {3}, ag::Dtype::Float64));
    if (step > 0) p[1].set_grad(ag::from_vector(std::vector<double>{-0.5, 0.05 * step}, {2}, ag::Dtype::Float64));
  };
  std::vector<ag::Tensor> straight = make_params();
  maps::optim::Adam a(straight, {.lr = 0.1});
  for (int step = 0; step < 6; ++step) {
    a.zero_grad();
    set_grads(straight, step);
    a.step();
  }
  std::vector<ag::Tensor> resumed = make_params();
  maps::optim::Adam b(resumed, {.lr = 0.1});
  for (int step = 0; step < 3; ++step) {
    b.zero_grad();
    set_grads(resumed, step);
    b.step();
  }
  const maps::nn::NamedTensors saved = b.state();
  std::vector<ag::Tensor> copy = {resumed[0].detach().clone(), resumed[1].detach().clone()};
  maps::optim::Adam c(copy, {.lr = 0.1});
  c.load_state(saved);
  EXPECT_EQ(c.step_count(0), 3);
  EXPECT_EQ(c.step_count(1), 2);
  for (int step = 3; step < 6; ++step) {
    c.zero_grad();
    set_grads(copy, step);
    c.step();
  }
  for (int i = 0; i < 2; ++i) EXPECT_EQ(copy[i].to_vector(), straight[i].to_vector()) << i;
}

TEST(Adam, LoadStateRejectsMismatchesAndKeepsItsState) {
  std::vector<ag::Tensor> p = {ag::zeros({3}, ag::Dtype::Float64)};
  maps::optim::Adam adam(p);
  maps::nn::NamedTensors bad = {{"step.0", ag::scalar_tensor(2.0, ag::Dtype::Float64)},
                                {"exp_avg.0", ag::zeros({4}, ag::Dtype::Float64)},
                                {"exp_avg_sq.0", ag::zeros({3}, ag::Dtype::Float64)}};
  EXPECT_THAT([&] { adam.load_state(bad); },
              ::testing::ThrowsMessage<std::invalid_argument>(::testing::HasSubstr("exp_avg.0")));
  bad[1].tensor = ag::zeros({3}, ag::Dtype::Float64);
  bad.push_back({"exp_avg.7", ag::zeros({3}, ag::Dtype::Float64)});
  EXPECT_THAT([&] { adam.load_state(bad); },
              ::testing::ThrowsMessage<std::invalid_argument>(::testing::HasSubstr("name no parameter")));
  EXPECT_EQ(adam.step_count(0), 0);
}

// A state from a file: a step count past 2^53 (whose cast to a whole number would be undefined), and moments that
// are not finite or a negative second moment (an infinite one would freeze its parameter without a word).
TEST(Adam, LoadStateRefusesCountsAndMomentsNoRunCouldHave) {
  std::vector<ag::Tensor> p = {ag::zeros({3}, ag::Dtype::Float64)};
  maps::optim::Adam adam(p);
  const auto state = [](double step, double first, double second) {
    maps::nn::NamedTensors s = {{"step.0", ag::scalar_tensor(step, ag::Dtype::Float64)},
                                {"exp_avg.0", ag::zeros({3}, ag::Dtype::Float64)},
                                {"exp_avg_sq.0", ag::zeros({3}, ag::Dtype::Float64)}};
    s[1].tensor.data<double>()[2] = first;
    s[2].tensor.data<double>()[0] = second;
    return s;
  };
  EXPECT_NO_THROW(adam.load_state(state(9007199254740992.0, -1.5, 0.25)));
  EXPECT_EQ(adam.step_count(0), 9007199254740992LL);
  for (const double step : {1e300, 9007199254740994.0, 0.0, 2.5})
    EXPECT_THAT(
        [&] { adam.load_state(state(step, 0.0, 0.0)); },
        ::testing::ThrowsMessage<std::invalid_argument>(::testing::HasSubstr("'step.0' must be a whole number")))
        << step;
  for (const double bad : {std::nan(""), double(INFINITY)})
    EXPECT_THAT([&] { adam.load_state(state(2.0, bad, 0.0)); },
                ::testing::ThrowsMessage<std::invalid_argument>(::testing::HasSubstr("'exp_avg.0' must hold finite")))
        << bad;
  for (const double bad : {std::nan(""), double(INFINITY), -1e-30})
    EXPECT_THAT([&] { adam.load_state(state(2.0, 0.0, bad)); },
                ::testing::ThrowsMessage<std::invalid_argument>(
                    ::testing::HasSubstr("'exp_avg_sq.0' must hold finite values >= 0")))
        << bad;
  EXPECT_EQ(adam.step_count(0), 9007199254740992LL);  // the refused states left the loaded one
}

}  // namespace
}  // namespace nntest
