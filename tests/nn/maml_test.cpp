// MAML's meta-gradient through the module API: one inner SGD step built with create_graph, the adapted
// weights put into a parameter-sharing clone with replace_parameter, and the query loss differentiated with
// respect to the initial parameters; checked against central finite differences in float64.

#include <optional>

#include "nn_test_util.h"

namespace nntest {
namespace {

struct Task {
  Tensor xs, ys, xq, yq;
};

Task make_task(std::uint64_t seed) {
  ag::Generator gen(seed);
  Task t;
  t.xs = ag::randn({6, 2}, gen, Dtype::Float64);
  t.ys = ag::randn({6, 1}, gen, Dtype::Float64);
  t.xq = ag::randn({5, 2}, gen, Dtype::Float64);
  t.yq = ag::randn({5, 1}, gen, Dtype::Float64);
  return t;
}

// L_query(theta - alpha * grad L_support(theta)), with theta read from model's slots.
Tensor meta_loss(const std::shared_ptr<nn::MLP>& model, const Task& task, double alpha, bool second_order) {
  const nn::NamedTensors theta = model->named_parameters();
  std::vector<Tensor> params;
  for (const auto& p : theta) params.push_back(p.tensor);
  auto learner = nn::clone_sharing_parameters(model);
  const Tensor support = ag::mse_loss(learner->forward(task.xs), task.ys);
  const std::vector<Tensor> grads = ag::grad({support}, params, {}, std::nullopt, /*create_graph=*/second_order);
  for (std::size_t i = 0; i < params.size(); ++i) {
    const Tensor g = second_order ? grads[i] : grads[i].detach();
    learner->replace_parameter(theta[i].name, params[i] - alpha * g);
  }
  return ag::mse_loss(learner->forward(task.xq), task.yq);
}

TEST(MAML, MetaGradientMatchesFiniteDifferences) {
  ag::Generator gen(91);
  auto model = std::make_shared<nn::MLP>(std::vector<std::int64_t>{2, 4, 1}, "tanh", gen);
  model->to(Dtype::Float64);
  const Task task = make_task(92);
  const double alpha = 0.5;
  const std::vector<Tensor> params = model->parameters();

  const Tensor loss = meta_loss(model, task, alpha, /*second_order=*/true);
  const std::vector<Tensor> analytic = ag::grad({loss}, params);
  const std::vector<Tensor> first_order = ag::grad({meta_loss(model, task, alpha, false)}, params);

  const double eps = 1e-6;
  double second_order_effect = 0.0;
  for (std::size_t k = 0; k < params.size(); ++k) {
    Tensor param = params[k];
    double* values = param.data<double>();
    for (std::int64_t e = 0; e < params[k].numel(); ++e) {
      const double original = values[e];
      values[e] = original + eps;
      const double plus = meta_loss(model, task, alpha, true).item();
      values[e] = original - eps;
      const double minus = meta_loss(model, task, alpha, true).item();
      values[e] = original;
      const double numerical = (plus - minus) / (2 * eps);
      const double a = analytic[k].at(e);
      EXPECT_NEAR(a, numerical, 1e-7 + 1e-5 * std::abs(numerical)) << "parameter " << k << " element " << e;
      second_order_effect = std::max(second_order_effect, std::abs(a - first_order[k].at(e)));
    }
  }
  // The Hessian term matters here: first-order MAML gives a visibly different gradient.
  EXPECT_GT(second_order_effect, 1e-3);
}

TEST(MAML, BackwardAccumulatesIntoTheOriginalParameters) {
  ag::Generator gen(93);
  auto model = std::make_shared<nn::MLP>(std::vector<std::int64_t>{2, 3, 1}, "tanh", gen);
  model->to(Dtype::Float64);
  const Task a = make_task(94), b = make_task(95);
  const std::vector<Tensor> params = model->parameters();
  const auto ga = ag::grad({meta_loss(model, a, 0.1, true)}, params);
  const auto gb = ag::grad({meta_loss(model, b, 0.1, true)}, params);
  // learn2learn's loop: one clone per task, backward on each query loss, grads summed in the originals.
  model->zero_grad();
  meta_loss(model, a, 0.1, true).backward();
  meta_loss(model, b, 0.1, true).backward();
  for (std::size_t k = 0; k < params.size(); ++k) {
    ASSERT_TRUE(params[k].grad().defined());
    EXPECT_LT(max_abs_diff(params[k].grad(), ga[k] + gb[k]), 1e-12);
    EXPECT_TRUE(params[k].is_leaf());
  }
}

}  // namespace
}  // namespace nntest
