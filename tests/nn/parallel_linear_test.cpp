#include <cmath>

#include "nn_test_util.h"

namespace nntest {
namespace {

TEST(ParallelLinear, InitEqualsSeparateLinearsFromTheSameGenerator) {
  const std::int64_t M = 3, in = 4, out = 5;
  ag::Generator g1(21), g2(21);
  nn::ParallelLinear pl(M, in, out, g1);
  EXPECT_EQ(pl.weight().shape(), (Shape{M, in, out}));
  EXPECT_EQ(pl.bias().shape(), (Shape{M, 1, out}));
  for (std::int64_t m = 0; m < M; ++m) {
    nn::Linear lin(in, out, g2);
    const Tensor wt = ag::reshape(ag::narrow(pl.weight(), 0, m, 1), {in, out});
    EXPECT_EQ(wt.to_vector(), ag::transpose(lin.weight(), 0, 1).to_vector()) << "member " << m;
    EXPECT_EQ(ag::reshape(ag::narrow(pl.bias(), 0, m, 1), {out}).to_vector(), lin.bias().to_vector());
  }
}

TEST(ParallelLinear, ForwardEqualsSeparateLinears) {
  const std::int64_t M = 4, B = 6, in = 3, out = 2;
  ag::Generator g1(22), g2(22), data(23);
  nn::ParallelLinear pl(M, in, out, g1);
  std::vector<std::shared_ptr<nn::Linear>> linears;
  for (std::int64_t m = 0; m < M; ++m) linears.push_back(std::make_shared<nn::Linear>(in, out, g2));

  // Batched input: member m sees x[m].
  const Tensor x = ag::randn({M, B, in}, data);
  const Tensor y = pl.forward(x);
  ASSERT_EQ(y.shape(), (Shape{M, B, out}));
  // Shared input: every member sees the same [B, in].
  const Tensor s = ag::randn({B, in}, data);
  const Tensor ys = pl.forward(s);
  ASSERT_EQ(ys.shape(), (Shape{M, B, out}));
  for (std::int64_t m = 0; m < M; ++m) {
    const Tensor xm = ag::reshape(ag::narrow(x, 0, m, 1), {B, in});
    EXPECT_LT(max_abs_diff(ag::reshape(ag::narrow(y, 0, m, 1), {B, out}), linears[m]->forward(xm)), 1e-6);
    EXPECT_LT(max_abs_diff(ag::reshape(ag::narrow(ys, 0, m, 1), {B, out}), linears[m]->forward(s)), 1e-6);
  }
}

TEST(ParallelLinear, BadInputNamesTheShapes) {
  ag::Generator gen(24);
  nn::ParallelLinear pl(3, 4, 5, gen);
  EXPECT_THAT(error_of([&] {
                pl.forward(ag::zeros({2, 6, 4}));
              }),
              ::testing::AllOf(HasSubstr("ParallelLinear(3, 4, 5)"), HasSubstr("[2, 6, 4]")));
  EXPECT_THAT(error_of([&] { pl.forward(ag::zeros({6, 3})); }), HasSubstr("[6, 3]"));
}

TEST(ParallelLinear, GradcheckBatchedAndShared) {
  ag::Generator gen(25), data(26);
  nn::ParallelLinear pl(2, 3, 2, gen);
  pl.to(Dtype::Float64);
  const Tensor x = ag::randn({2, 4, 3}, data, Dtype::Float64).requires_grad_();
  auto r = ag::gradcheck("ParallelLinear", [&](const std::vector<Tensor>& in) { return pl.forward(in[0]); },
                         {x, pl.weight(), pl.bias()});
  EXPECT_TRUE(r.ok) << r.message;
  const Tensor s = ag::randn({4, 3}, data, Dtype::Float64).requires_grad_();
  r = ag::gradcheck("ParallelLinear(shared)", [&](const std::vector<Tensor>& in) { return pl.forward(in[0]); },
                    {s, pl.weight(), pl.bias()});
  EXPECT_TRUE(r.ok) << r.message;
}

}  // namespace
}  // namespace nntest
