#include "maps/selector/selector_loss.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "autograd/gradcheck.h"

namespace maps::core {
namespace {

using ag::Dtype;
using ag::Tensor;
using ::testing::HasSubstr;

Tensor values(const std::vector<double>& v, const ag::Shape& shape) {
  return ag::from_vector(v, shape, Dtype::Float64);
}

// K = 2 tasks, b = 2 states, M = 2 modules; state 0's scores differ between the tasks, state 1's do not.
SelectorOutputs small_batch() {
  SelectorOutputs out;
  out.all_task_scores = values({0.7, 0.3, 0.4, 0.6, /* task 1: */ 0.5, 0.5, 0.4, 0.6}, {2, 2, 2});
  out.tasks = {0, 1};
  out.scores = values({0.7, 0.3, 0.4, 0.6}, {2, 2});  // state 0 under task 0, state 1 under task 1
  out.previous_scores = values({0.6, 0.4, 0.4, 0.6}, {2, 2});
  out.num_tasks = 2;
  out.num_modules = 2;
  return out;
}

TEST(SelectorLosses, HandComputedValues) {
  const SelectorOutputs out = small_batch();
  // share: state 0 differs by (0.2, -0.2) between the tasks: 2 ordered pairs x 0.08 = 0.16 over K(K-1) b M = 8.
  EXPECT_NEAR(make_share_loss()->forward(out).item(), 0.02, 1e-15);
  // explore: usage (1.1, 0.9) around b/M = 1: (M / b^2) (0.01 + 0.01) = 0.01.
  EXPECT_NEAR(make_explore_loss()->forward(out).item(), 0.01, 1e-15);
  // sparse: -(1/(M b)) sum g^(1/log 2) log g.
  double sparse = 0.0;
  for (double g : {0.7, 0.3, 0.4, 0.6}) sparse += std::pow(g, 1.0 / std::log(2.0)) * std::log(g);
  EXPECT_NEAR(make_sparse_loss()->forward(out).item(), -sparse / 4.0, 1e-15);
  // smooth: state 0 moved by (0.1, -0.1): 0.02 / (M b = 4).
  EXPECT_NEAR(make_smooth_loss()->forward(out).item(), 0.005, 1e-15);
}

TEST(SelectorLosses, ExploreIsTheSquaredCoefficientOfVariationOfUsage) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const int b = 7, M = 5;
  std::vector<double> g(b * M);
  for (int s = 0; s < b; ++s) {
    double total = 0.0;
    for (int i = 0; i < M; ++i) total += (g[s * M + i] = u(rng));
    for (int i = 0; i < M; ++i) g[s * M + i] /= total;
  }
  std::vector<double> usage(M, 0.0);
  for (int s = 0; s < b; ++s)
    for (int i = 0; i < M; ++i) usage[i] += g[s * M + i];
  double mean = 0.0, var = 0.0;
  for (double x : usage) mean += x / M;
  for (double x : usage) var += (x - mean) * (x - mean) / M;
  SelectorOutputs out;
  out.scores = values(g, {b, M});
  EXPECT_NEAR(make_explore_loss()->forward(out).item(), var / (mean * mean), 1e-14);
}

TEST(SelectorLosses, SparseIsLargestAtUniformScores) {
  const int M = 6;
  SelectorOutputs uniform;
  uniform.scores = ag::full({1, M}, 1.0 / M, Dtype::Float64);
  const double at_uniform = make_sparse_loss()->forward(uniform).item();
  std::mt19937_64 rng(5);
  std::gamma_distribution<double> gamma(0.5, 1.0);
  for (int trial = 0; trial < 200; ++trial) {
    std::vector<double> g(M);
    double total = 0.0;
    for (double& x : g) total += (x = gamma(rng) + 1e-9);
    for (double& x : g) x /= total;
    SelectorOutputs out;
    out.scores = values(g, {1, M});
    EXPECT_LE(make_sparse_loss()->forward(out).item(), at_uniform + 1e-12) << trial;
  }
  // One-hot scores are as sparse as can be: the loss is 0 there.
  SelectorOutputs one_hot;
  one_hot.scores = ag::one_hot({2}, M, Dtype::Float64);
  EXPECT_NEAR(make_sparse_loss()->forward(one_hot).item(), 0.0, 1e-12);
}

TEST(SelectorLosses, ShareIsZeroWhenTasksAgreeAndForOneTask) {
  SelectorOutputs out = small_batch();
  out.all_task_scores = values({0.7, 0.3, 0.4, 0.6, 0.7, 0.3, 0.4, 0.6}, {2, 2, 2});
  EXPECT_NEAR(make_share_loss()->forward(out).item(), 0.0, 1e-15);
  out.all_task_scores = values({0.7, 0.3, 0.4, 0.6}, {1, 2, 2});
  EXPECT_EQ(make_share_loss()->forward(out).item(), 0.0);
}

// The pairwise definition, summed in long double: the reference the one-pass form must match.
double pairwise_share(const std::vector<double>& a, std::int64_t K, std::int64_t b, std::int64_t M) {
  long double sum = 0.0L;
  for (std::int64_t k1 = 0; k1 < K; ++k1)
    for (std::int64_t k2 = 0; k2 < K; ++k2)
      for (std::int64_t j = 0; j < b * M; ++j) {
        const long double d = static_cast<long double>(a[static_cast<std::size_t>(k1 * b * M + j)]) -
                              static_cast<long double>(a[static_cast<std::size_t>(k2 * b * M + j)]);
        sum += d * d;
      }
  return static_cast<double>(sum / static_cast<long double>(K * (K - 1) * b * M));
}

// Near its optimum (tasks almost agreeing) the share term must keep its digits: the form
// 2K sum a^2 - 2 (sum_k a)^2 cancelled there (negative values, 37% error near 1e-8 in float32).
TEST(SelectorLosses, ShareIsNeverNegativeAndAccurateNearZero) {
  const std::int64_t K = 10, b = 32, M = 10;
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::vector<double> base(static_cast<std::size_t>(b * M));
  for (double& v : base) v = unit(rng);
  for (const double spread : {1e-1, 1e-3, 1e-5, 1e-7}) {
    std::vector<double> a;
    for (std::int64_t k = 0; k < K; ++k)
      for (double v : base) a.push_back(v + spread * (unit(rng) - 0.5));
    const double reference = pairwise_share(a, K, b, M);
    SelectorOutputs out = small_batch();
    out.all_task_scores = ag::from_vector(a, {K, b, M}, Dtype::Float64);
    EXPECT_NEAR(make_share_loss()->forward(out).item(), reference, 1e-12 * reference) << "float64, spread " << spread;
    // float32 scores: rounding the inputs alone changes the reference; compare with the float32-rounded inputs'.
    std::vector<double> rounded;
    for (double v : a) rounded.push_back(static_cast<double>(static_cast<float>(v)));
    const double rounded_reference = pairwise_share(rounded, K, b, M);
    out.all_task_scores = ag::from_vector(a, {K, b, M}, Dtype::Float32);
    const double single = make_share_loss()->forward(out).item();
    EXPECT_GE(single, 0.0) << "spread " << spread;
    EXPECT_NEAR(single, rounded_reference, 1e-3 * rounded_reference) << "float32, spread " << spread;
  }
  // Exactly agreeing tasks: exactly 0 in both dtypes.
  std::vector<double> same;
  for (std::int64_t k = 0; k < K; ++k) same.insert(same.end(), base.begin(), base.end());
  for (const Dtype dtype : {Dtype::Float32, Dtype::Float64}) {
    SelectorOutputs out = small_batch();
    out.all_task_scores = ag::from_vector(same, {K, b, M}, dtype);
    EXPECT_EQ(make_share_loss()->forward(out).item(), 0.0);
  }
}

// Each loss as a function of selector logits (softmax keeps the scores valid as gradcheck perturbs them).
TEST(SelectorLosses, PassGradcheck) {
  const int K = 3, b = 4, M = 5;
  ag::Generator gen(11);
  const Tensor all_logits = ag::randn({K * b, M}, gen, Dtype::Float64).requires_grad_();
  const Tensor prev_logits = ag::randn({b, M}, gen, Dtype::Float64).requires_grad_();
  const std::vector<std::int64_t> tasks = {0, 2, 1, 2};
  for (const auto& entry : selector_losses()) {
    auto loss = entry.make();
    const auto f = [&](const std::vector<Tensor>& in) {
      SelectorOutputs out;
      const Tensor all = ag::softmax(in[0], 1);
      out.all_task_scores = all.reshape({K, b, M});
      std::vector<std::int64_t> rows;
      for (int j = 0; j < b; ++j) rows.push_back(tasks[j] * b + j);
      out.scores = ag::index_select(all, rows);
      out.previous_scores = ag::softmax(in[1], 1);
      out.tasks = tasks;
      out.num_tasks = K;
      out.num_modules = M;
      return loss->forward(out);
    };
    const auto result = ag::gradcheck(entry.name, ag::SingleFunction(f), {all_logits, prev_logits});
    EXPECT_TRUE(result.ok) << result.message;
    const auto second = ag::gradgradcheck(entry.name, ag::SingleFunction(f), {all_logits, prev_logits});
    EXPECT_TRUE(second.ok) << second.message;
  }
}

// The built-ins come first, in the paper's order; others may follow (registered ones: selector_registry_test.cpp).
TEST(SelectorLosses, RegistryNamesEveryBuiltInFirstAndRejectsUnknownOnes) {
  std::vector<std::string> names;
  for (const auto& entry : selector_losses()) names.push_back(entry.name);
  ASSERT_GE(names.size(), 4u);
  EXPECT_THAT(std::vector<std::string>(names.begin(), names.begin() + 4),
              ::testing::ElementsAre("share", "explore", "sparse", "smooth"));
  EXPECT_EQ(make_selector_loss("smooth")->name(), "smooth");
  EXPECT_THAT([] { make_selector_loss("entropy"); },
              ::testing::ThrowsMessage<std::invalid_argument>(
                  ::testing::AllOf(HasSubstr("entropy"), HasSubstr("share, explore, sparse, smooth"))));
}

}  // namespace
}  // namespace maps::core
