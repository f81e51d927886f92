// Tensor: factories, conversions, element access, autograd state of leaves, shape errors.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <cmath>
#include <numeric>
#include <vector>

#include "autograd/autograd.h"
#include "tests/autograd/test_util.h"

namespace {

namespace ag = maps::ag;
using ag::Dtype;
using ag::Shape;
using ag::Tensor;
using agtest::expect_throw_with;
using agtest::expect_values;
using agtest::kBothDtypes;
using agtest::kF32;
using agtest::kF64;
using agtest::tensor;

TEST(Shape, ToStringFormat) {
  EXPECT_EQ(ag::to_string(Shape{2, 3}), "[2, 3]");
  EXPECT_EQ(ag::to_string(Shape{4}), "[4]");
  EXPECT_EQ(ag::to_string(Shape{}), "[]");
  EXPECT_EQ(ag::numel_of(Shape{}), 1);
  EXPECT_EQ(ag::numel_of(Shape{2, 3, 4}), 24);
  EXPECT_EQ(ag::numel_of(Shape{2, 0}), 0);
}

TEST(Shape, BroadcastShapes) {
  EXPECT_EQ(ag::broadcast_shapes({3, 4}, {4}, "add"), (Shape{3, 4}));
  EXPECT_EQ(ag::broadcast_shapes({3, 1}, {1, 4}, "mul"), (Shape{3, 4}));
  EXPECT_EQ(ag::broadcast_shapes({2, 3, 4}, {3, 1}, "div"), (Shape{2, 3, 4}));
  EXPECT_EQ(ag::broadcast_shapes({}, {2, 3}, "add"), (Shape{2, 3}));
  EXPECT_EQ(ag::broadcast_shapes({2, 3}, {}, "add"), (Shape{2, 3}));
  expect_throw_with([] { ag::broadcast_shapes({2, 3}, {4}, "myop"); }, {"myop", "[2, 3]", "[4]"});
}

TEST(Shape, NormalizeDim) {
  EXPECT_EQ(ag::normalize_dim(-1, 3, "op"), 2);
  EXPECT_EQ(ag::normalize_dim(0, 3, "op"), 0);
  expect_throw_with([] { ag::normalize_dim(3, 3, "myop"); }, {"myop"});
  expect_throw_with([] { ag::normalize_dim(-4, 3, "myop"); }, {"myop"});
  EXPECT_EQ(ag::contiguous_strides({2, 3, 4}), (std::vector<std::int64_t>{12, 4, 1}));
}

TEST(TensorFactories, ZerosOnesFull) {
  for (Dtype dtype : kBothDtypes) {
    SCOPED_TRACE(ag::to_string(dtype));
    Tensor z = ag::zeros({2, 3}, dtype);
    EXPECT_EQ(z.dtype(), dtype);
    EXPECT_EQ(z.dim(), 2);
    EXPECT_EQ(z.size(0), 2);
    EXPECT_EQ(z.size(-1), 3);
    expect_values(z, {2, 3}, std::vector<double>(6, 0.0));
    expect_values(ag::ones({4}, dtype), {4}, std::vector<double>(4, 1.0));
    expect_values(ag::full({2, 2}, 3.5, dtype), {2, 2}, std::vector<double>(4, 3.5));
    Tensor s = ag::scalar_tensor(-2.25, dtype);
    EXPECT_EQ(s.dim(), 0);
    EXPECT_EQ(s.numel(), 1);
    EXPECT_EQ(s.item(), -2.25);
    EXPECT_FALSE(z.requires_grad());
    EXPECT_TRUE(z.is_leaf());
    EXPECT_EQ(z.grad_fn(), nullptr);
  }
  EXPECT_EQ(ag::zeros({2}).dtype(), kF32);  // float32 by default
}

TEST(TensorFactories, LikeFactoriesKeepShapeAndDtype) {
  Tensor x = tensor({1, 2, 3, 4, 5, 6}, {3, 2}, kF64, true);
  Tensor z = ag::zeros_like(x);
  Tensor o = ag::ones_like(x);
  Tensor f = ag::full_like(x, 7.0);
  for (const Tensor& t : {z, o, f}) {
    EXPECT_EQ(t.shape(), (Shape{3, 2}));
    EXPECT_EQ(t.dtype(), kF64);
    EXPECT_FALSE(t.requires_grad());
  }
  expect_values(f, {3, 2}, std::vector<double>(6, 7.0));
  expect_values(o, {3, 2}, std::vector<double>(6, 1.0));
}

TEST(TensorFactories, Arange) {
  for (Dtype dtype : kBothDtypes) {
    SCOPED_TRACE(ag::to_string(dtype));
    Tensor a = ag::arange(0, 5, 1, dtype);
    EXPECT_EQ(a.dtype(), dtype);
    expect_values(a, {5}, {0, 1, 2, 3, 4});
    expect_values(ag::arange(1, 2, 0.25, dtype), {4}, {1, 1.25, 1.5, 1.75});
    expect_values(ag::arange(3, -1, -1.5, dtype), {3}, {3, 1.5, 0});
    expect_values(ag::arange(0, 5, 2, dtype), {3}, {0, 2, 4});  // end not reached exactly
    EXPECT_EQ(ag::arange(2, 2, 1, dtype).numel(), 0);
  }
  EXPECT_THROW(ag::arange(0, 1, 0), std::exception);
}

TEST(TensorFactories, RandIsSeededAndInRange) {
  for (Dtype dtype : kBothDtypes) {
    SCOPED_TRACE(ag::to_string(dtype));
    ag::Generator g1(42);
    ag::Generator g2(42);
    ag::Generator g3(43);
    Tensor a = ag::rand({10, 10}, g1, dtype, -2.0, 3.0);
    Tensor b = ag::rand({10, 10}, g2, dtype, -2.0, 3.0);
    Tensor c = ag::rand({10, 10}, g3, dtype, -2.0, 3.0);
    EXPECT_EQ(a.dtype(), dtype);
    EXPECT_EQ(a.to_vector(), b.to_vector());
    EXPECT_NE(a.to_vector(), c.to_vector());
    for (double v : a.to_vector()) {
      EXPECT_GE(v, -2.0);
      EXPECT_LE(v, 3.0);  // float32 rounding may reach the bound itself
    }
    // The generator advances: a second draw differs from the first.
    Tensor a2 = ag::rand({10, 10}, g1, dtype, -2.0, 3.0);
    EXPECT_NE(a.to_vector(), a2.to_vector());
    // Reseeding repeats the sequence.
    g1.seed(42);
    EXPECT_EQ(ag::rand({10, 10}, g1, dtype, -2.0, 3.0).to_vector(), a.to_vector());
  }
  ag::Generator gen(1);
  Tensor u = ag::rand({4000}, gen, kF64);
  std::vector<double> v = u.to_vector();
  const double mean = std::accumulate(v.begin(), v.end(), 0.0) / static_cast<double>(v.size());
  EXPECT_NEAR(mean, 0.5, 0.03);
  for (double x : v) {
    EXPECT_GE(x, 0.0);
    EXPECT_LT(x, 1.0);
  }
}

TEST(TensorFactories, RandnIsSeededAndStandardNormal) {
  for (Dtype dtype : kBothDtypes) {
    SCOPED_TRACE(ag::to_string(dtype));
    ag::Generator g1(7);
    ag::Generator g2(7);
    Tensor a = ag::randn({3, 4}, g1, dtype);
    Tensor b = ag::randn({3, 4}, g2, dtype);
    EXPECT_EQ(a.dtype(), dtype);
    EXPECT_EQ(a.shape(), (Shape{3, 4}));
    EXPECT_EQ(a.to_vector(), b.to_vector());
  }
  ag::Generator gen(3);
  std::vector<double> v = ag::randn({20000}, gen, kF64).to_vector();
  const double mean = std::accumulate(v.begin(), v.end(), 0.0) / static_cast<double>(v.size());
  double var = 0;
  for (double x : v) var += (x - mean) * (x - mean);
  var /= static_cast<double>(v.size());
  EXPECT_NEAR(mean, 0.0, 0.03);
  EXPECT_NEAR(std::sqrt(var), 1.0, 0.03);
  for (double x : v) EXPECT_TRUE(std::isfinite(x));
}

TEST(TensorFactories, FromVectorRoundTrip) {
  const std::vector<double> values = {1.5, -2, 3.25, 4, 5, 6};
  for (Dtype dtype : kBothDtypes) {
    SCOPED_TRACE(ag::to_string(dtype));
    Tensor t = ag::from_vector(values, {2, 3}, dtype);
    EXPECT_EQ(t.dtype(), dtype);
    EXPECT_EQ(t.to_vector(), values);
    EXPECT_EQ(t.at(4), 5.0);
  }
  Tensor f = ag::from_vector(std::vector<float>{1.5f, 2.5f}, {2});
  EXPECT_EQ(f.dtype(), kF32);
  EXPECT_EQ(f.to_vector(), (std::vector<double>{1.5, 2.5}));
  Tensor s = ag::from_vector(std::vector<double>{9.0}, {}, kF64);
  EXPECT_EQ(s.item(), 9.0);
}

TEST(TensorFactories, FromVectorWrongSizeThrows) {
  expect_throw_with([] { ag::from_vector(std::vector<double>{1, 2, 3}, {2, 2}, kF64); }, {"[2, 2]"});
  expect_throw_with([] { ag::from_vector(std::vector<float>{1, 2, 3, 4, 5}, {2, 2}); }, {"[2, 2]"});
  EXPECT_THROW(ag::from_vector(std::vector<double>{1, 2}, {}, kF64), std::exception);
}

TEST(TensorFactories, FromEigenColumnMajorAndExpressions) {
  Eigen::MatrixXd m(2, 3);  // column-major
  m << 1, 2, 3, 4, 5, 6;
  Tensor t = ag::from_eigen(m);
  EXPECT_EQ(t.dtype(), kF64);
  expect_values(t, {2, 3}, {1, 2, 3, 4, 5, 6});  // row-major order in the tensor
  expect_values(ag::from_eigen(m.transpose()), {3, 2}, {1, 4, 2, 5, 3, 6});
  expect_values(ag::from_eigen(m.block(0, 1, 2, 2)), {2, 2}, {2, 3, 5, 6});

  Eigen::MatrixXf mf(3, 1);
  mf << 0.5f, -1.0f, 2.0f;
  Tensor tf = ag::from_eigen(mf);
  EXPECT_EQ(tf.dtype(), kF32);
  expect_values(tf, {3, 1}, {0.5, -1, 2});

  ag::RowMatrixD back = ag::to_eigen_double(t);
  EXPECT_EQ(back.rows(), 2);
  EXPECT_EQ(back.cols(), 3);
  EXPECT_TRUE(back.isApprox(m));
  ag::RowMatrixF backf = ag::to_eigen_float(tf);
  EXPECT_TRUE(backf.isApprox(mf));
}

TEST(TensorFactories, ToEigenOneDimIsARowAndHigherRankThrows) {
  Tensor v = tensor({1, 2, 3}, {3});
  ag::RowMatrixD m = ag::to_eigen_double(v);
  EXPECT_EQ(m.rows(), 1);
  EXPECT_EQ(m.cols(), 3);
  EXPECT_EQ(m(0, 2), 3.0);
  EXPECT_THROW(ag::to_eigen_double(ag::zeros({2, 2, 2}, kF64)), std::exception);
  EXPECT_THROW(ag::to_eigen_float(ag::zeros({2, 2, 2}, kF32)), std::exception);
}

TEST(TensorAccess, MatrixAndArrayViewsShareStorage) {
  Tensor t = tensor({1, 2, 3, 4, 5, 6}, {2, 3});
  auto m = t.matrix<double>();
  EXPECT_EQ(m.rows(), 2);
  EXPECT_EQ(m.cols(), 3);
  EXPECT_EQ(m(1, 0), 4.0);
  m(0, 1) = 20.0;
  EXPECT_EQ(t.at(1), 20.0);
  t.array<double>() *= 2.0;
  expect_values(t, {2, 3}, {2, 40, 6, 8, 10, 12});
  EXPECT_THROW(t.data<float>(), std::exception);
  EXPECT_THROW(t.matrix<float>(), std::exception);
  Tensor f = ag::ones({2}, kF32);
  EXPECT_THROW(f.data<double>(), std::exception);
  EXPECT_EQ(f.data<float>()[1], 1.0f);
}

TEST(TensorAccess, ItemAndAt) {
  EXPECT_EQ(tensor({4.5}, {1, 1}).item(), 4.5);
  EXPECT_EQ(tensor({-3}, {}).item(), -3.0);
  EXPECT_EQ(tensor({2.5}, {1}, kF32).item(), 2.5);
  expect_throw_with([] { tensor({1, 2}, {2}).item(); }, {"item", "[2]"});
  Tensor t = tensor({1, 2, 3}, {3});
  EXPECT_THROW(t.at(3), std::exception);
  EXPECT_THROW(t.at(-1), std::exception);
}

TEST(TensorAccess, UndefinedTensor) {
  Tensor u;
  EXPECT_FALSE(u.defined());
  EXPECT_THROW(u.shape(), std::exception);
  EXPECT_THROW(u.numel(), std::exception);
  EXPECT_FALSE(ag::ones({1}).grad().defined());
}

TEST(TensorConvert, ToDtypeValues) {
  Tensor d = tensor({0.1, -1.5, 1e10, 3}, {2, 2}, kF64);
  Tensor f = d.to(kF32);
  EXPECT_EQ(f.dtype(), kF32);
  EXPECT_EQ(f.shape(), (Shape{2, 2}));
  const std::vector<double> fv = f.to_vector();
  EXPECT_EQ(fv[0], static_cast<double>(0.1f));
  EXPECT_EQ(fv[1], -1.5);
  EXPECT_EQ(fv[2], static_cast<double>(1e10f));
  Tensor back = f.to(kF64);
  EXPECT_EQ(back.dtype(), kF64);
  EXPECT_EQ(back.to_vector(), fv);
  // Same dtype: the same tensor.
  EXPECT_EQ(d.to(kF64).impl(), d.impl());
}

TEST(TensorConvert, ToDtypeIsDifferentiable) {
  Tensor x = tensor({1, 2, 3}, {3}, kF64, true);
  Tensor y = ag::sum(ag::mul(x.to(kF32), 2.0));
  EXPECT_EQ(y.dtype(), kF32);
  EXPECT_TRUE(y.requires_grad());
  y.backward();
  ASSERT_TRUE(x.grad().defined());
  EXPECT_EQ(x.grad().dtype(), kF64);
  expect_values(x.grad(), {3}, {2, 2, 2});
}

TEST(TensorConvert, CloneCopiesAndIsDifferentiable) {
  Tensor x = tensor({1, 2, 3}, {3}, kF64, true);
  Tensor c = x.clone();
  EXPECT_NE(c.impl()->storage, x.impl()->storage);
  EXPECT_EQ(c.to_vector(), x.to_vector());
  EXPECT_TRUE(c.requires_grad());
  EXPECT_FALSE(c.is_leaf());
  agtest::expect_grad_and_gradgrad("clone", [](const std::vector<Tensor>& in) { return in[0].clone(); },
                                   {agtest::randn64({2, 3}, 1)});
}

TEST(TensorAutograd, DetachSharesStorageWithoutGraph) {
  Tensor x = tensor({1, 2, 3}, {3}, kF64, true);
  Tensor y = ag::mul(x, 2.0);
  Tensor d = y.detach();
  EXPECT_EQ(d.impl()->storage, y.impl()->storage);
  EXPECT_EQ(d.grad_fn(), nullptr);
  EXPECT_FALSE(d.requires_grad());
  EXPECT_TRUE(d.is_leaf());
  d.data<double>()[0] = 10.0;
  EXPECT_EQ(y.at(0), 10.0);
  // Operations on a detached tensor record nothing.
  Tensor z = ag::mul(d, d);
  EXPECT_FALSE(z.requires_grad());
  EXPECT_EQ(z.grad_fn(), nullptr);
  // Detaching a leaf also gives a tensor that does not require grad.
  EXPECT_FALSE(x.detach().requires_grad());
  EXPECT_EQ(x.detach().impl()->storage, x.impl()->storage);
}

TEST(TensorAutograd, RequiresGradOnLeafOnly) {
  Tensor x = tensor({1, 2}, {2});
  EXPECT_FALSE(x.requires_grad());
  EXPECT_TRUE(x.is_leaf());
  Tensor& ref = x.requires_grad_();
  EXPECT_EQ(&ref, &x);
  EXPECT_TRUE(x.requires_grad());
  x.requires_grad_(false);
  EXPECT_FALSE(x.requires_grad());
  x.requires_grad_(true);
  Tensor y = ag::exp(x);
  EXPECT_TRUE(y.requires_grad());
  EXPECT_FALSE(y.is_leaf());
  ASSERT_NE(y.grad_fn(), nullptr);
  EXPECT_EQ(y.grad_fn()->op(), "exp");
  EXPECT_THROW(y.requires_grad_(), std::exception);
  EXPECT_THROW(y.requires_grad_(false), std::exception);
}

TEST(TensorAutograd, SetGradChecksShapeAndDtype) {
  Tensor x = tensor({1, 2}, {2}, kF64, true);
  x.set_grad(tensor({3, 4}, {2}));
  expect_values(x.grad(), {2}, {3, 4});
  EXPECT_THROW(x.set_grad(tensor({1, 2, 3}, {3})), std::exception);
  EXPECT_THROW(x.set_grad(tensor({1, 2}, {2}, kF32)), std::exception);
  x.set_grad(Tensor());
  EXPECT_FALSE(x.grad().defined());
}

TEST(TensorMutation, CopyAndFill) {
  Tensor a = ag::zeros({2, 2}, kF64);
  a.copy_(tensor({1, 2, 3, 4}, {2, 2}));
  expect_values(a, {2, 2}, {1, 2, 3, 4});
  a.fill_(-1.0);
  expect_values(a, {2, 2}, {-1, -1, -1, -1});
  EXPECT_THROW(a.copy_(tensor({1, 2, 3, 4}, {4})), std::exception);
  EXPECT_THROW(a.copy_(tensor({1, 2, 3, 4}, {2, 2}, kF32)), std::exception);
  Tensor f = ag::zeros({3}, kF32);
  f.fill_(0.5);
  expect_values(f, {3}, {0.5, 0.5, 0.5});
}

TEST(TensorShape, ReshapeWithInferredDim) {
  Tensor x = tensor({1, 2, 3, 4, 5, 6}, {2, 3});
  Tensor r = x.reshape({-1, 2});
  expect_values(r, {3, 2}, {1, 2, 3, 4, 5, 6});
  EXPECT_EQ(r.impl()->storage, x.impl()->storage);  // a reshaped view shares storage
  expect_values(x.reshape({-1}), {6}, {1, 2, 3, 4, 5, 6});
  expect_values(x.reshape({1, -1, 1}), {1, 6, 1}, {1, 2, 3, 4, 5, 6});
  expect_values(tensor({5}, {1, 1}).reshape({}), {}, {5});
  expect_throw_with([&] { x.reshape({4, 2}); }, {"reshape", "[2, 3]", "[4, 2]"});
  expect_throw_with([&] { x.reshape({-1, 4}); }, {"reshape"});
  expect_throw_with([&] { x.reshape({-1, -1}); }, {"reshape"});
}

TEST(TensorShape, ToStringShowsShapeAndDtype) {
  const std::string s = tensor({1, 2}, {2}, kF64).to_string();
  EXPECT_THAT(s, ::testing::HasSubstr("[2]"));
  EXPECT_THAT(s, ::testing::HasSubstr("float64"));
  EXPECT_EQ(Tensor().to_string().empty(), false);
}

TEST(TensorShape, ShapeTextNamesTheShapeOrAnUndefinedTensor) {
  EXPECT_EQ(ag::shape_text(tensor({1, 2, 3, 4, 5, 6}, {2, 3})), "[2, 3]");
  EXPECT_EQ(ag::shape_text(tensor({5}, {})), "[]");
  EXPECT_EQ(ag::shape_text(Tensor()), "an undefined tensor");
}

TEST(GradMode, GuardsNestAndRestore) {
  EXPECT_TRUE(ag::GradMode::is_enabled());
  {
    ag::NoGradGuard no_grad;
    EXPECT_FALSE(ag::GradMode::is_enabled());
    {
      ag::AutoGradMode enable(true);
      EXPECT_TRUE(ag::GradMode::is_enabled());
    }
    EXPECT_FALSE(ag::GradMode::is_enabled());
  }
  EXPECT_TRUE(ag::GradMode::is_enabled());
}

}  // namespace
