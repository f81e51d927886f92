#pragma once

#include <vector>

#include "../nn_test_util.h"

namespace nntest {

// The fixed problem behind the PyTorch reference numbers in adam_test.cpp and sgd_test.cpp (see the Python
// snippet there): p [2,2] and q [3], five steps with these grads; q has no grad at step 3.
// Returns p's four values then q's three after the steps.
template <typename MakeOptimizer>
std::vector<double> run_reference_problem(Dtype dtype, MakeOptimizer&& make) {
  Tensor p = ag::from_vector({0.5, -1.0, 2.0, 0.0}, {2, 2}, dtype).requires_grad_();
  Tensor q = ag::from_vector({1.5, -0.25, 0.75}, {3}, dtype).requires_grad_();
  auto opt = make(std::vector<Tensor>{p, q});
  for (int t = 1; t <= 5; ++t) {
    p.set_grad(ag::from_vector({0.1 * t, -0.2, 0.3 / t, -0.05 * t * t}, {2, 2}, dtype));
    q.set_grad(t == 3 ? Tensor() : ag::from_vector({0.01, -1.0 * t, 2.0}, {3}, dtype));
    opt.step();
  }
  std::vector<double> out = p.to_vector();
  for (double v : q.to_vector()) out.push_back(v);
  return out;
}

inline void expect_all_near(const std::vector<double>& got, const std::vector<double>& expected, double rel_tol) {
  ASSERT_EQ(got.size(), expected.size());
  for (std::size_t i = 0; i < got.size(); ++i)
    EXPECT_NEAR(got[i], expected[i], rel_tol * std::max(1.0, std::abs(expected[i]))) << "element " << i;
}

}  // namespace nntest
