// Shape ops: reshape, transpose, expand, sum_to, concat, stack, narrow/slice, index_select, index_add.

#include <gtest/gtest.h>

#include <cstdint>
#include <string>
#include <vector>

#include "autograd/autograd.h"
#include "tests/autograd/test_util.h"

namespace {

namespace ag = maps::ag;
using ag::Dtype;
using ag::Shape;
using ag::Tensor;
using agtest::expect_grad_and_gradgrad;
using agtest::expect_gradcheck;
using agtest::expect_throw_with;
using agtest::expect_values;
using agtest::kBothDtypes;
using agtest::kF32;
using agtest::kF64;
using agtest::randn64;
using agtest::tensor;

using Inputs = std::vector<Tensor>;

// 0, 1, 2, ... in `shape`.
Tensor iota(const Shape& shape, Dtype dtype = kF64) {
  return ag::arange(0, static_cast<double>(ag::numel_of(shape)), 1, dtype).reshape(shape);
}

std::vector<double> iota_values(std::int64_t n) {
  std::vector<double> v(static_cast<std::size_t>(n));
  for (std::size_t i = 0; i < v.size(); ++i) v[i] = static_cast<double>(i);
  return v;
}

// ----- reshape -----

TEST(Reshape, ForwardKeepsRowMajorOrder) {
  for (Dtype dtype : kBothDtypes) {
    SCOPED_TRACE(ag::to_string(dtype));
    const Tensor x = iota({2, 3, 4}, dtype);
    expect_values(ag::reshape(x, {4, 6}), {4, 6}, iota_values(24));
    expect_values(ag::reshape(x, {-1, 4}), {6, 4}, iota_values(24));
    expect_values(ag::reshape(x, {2, -1}), {2, 12}, iota_values(24));
    expect_values(ag::reshape(x, {24}), {24}, iota_values(24));
    expect_values(ag::reshape(iota({1}, dtype), {}), {}, {0});
    expect_values(ag::reshape(iota({}, dtype), {1, 1}), {1, 1}, {0});
  }
}

TEST(Reshape, GradcheckAndGradgradcheck) {
  std::uint64_t seed = 1;
  for (const auto& [from, target] : std::vector<std::pair<Shape, Shape>>{
           {{2, 3}, {3, 2}}, {{6}, {2, -1, 1}}, {{2, 3, 4}, {4, 6}}, {{1}, {}}, {{}, {1, 1}}}) {
    SCOPED_TRACE(ag::to_string(from) + " -> " + ag::to_string(target));
    const Shape to = target;  // a copy the lambdas can capture
    auto f = [to](const Inputs& in) { return ag::reshape(in[0], to); };
    expect_grad_and_gradgrad("reshape", f, {randn64(from, seed++)});
    auto method = [to](const Inputs& in) { return in[0].reshape(to); };
    expect_gradcheck("reshape", method, {randn64(from, seed++)});
  }
}

TEST(Reshape, Errors) {
  const Tensor x = ag::ones({2, 3});
  expect_throw_with([&] { ag::reshape(x, {5}); }, {"reshape", "[2, 3]", "[5]"});
  expect_throw_with([&] { ag::reshape(x, {-1, 4}); }, {"reshape", "[2, 3]"});
  expect_throw_with([&] { ag::reshape(x, {-1, -1}); }, {"reshape"});
}

// ----- transpose -----

TEST(Transpose, Forward2d) {
  for (Dtype dtype : kBothDtypes) {
    SCOPED_TRACE(ag::to_string(dtype));
    const Tensor x = tensor({1, 2, 3, 4, 5, 6}, {2, 3}, dtype);
    expect_values(ag::transpose(x, 0, 1), {3, 2}, {1, 4, 2, 5, 3, 6});
    expect_values(x.t(), {3, 2}, {1, 4, 2, 5, 3, 6});
    expect_values(x.transpose(-1, -2), {3, 2}, {1, 4, 2, 5, 3, 6});
    expect_values(ag::transpose(x, 1, 1), {2, 3}, {1, 2, 3, 4, 5, 6});
  }
}

TEST(Transpose, Forward3d) {
  for (Dtype dtype : kBothDtypes) {
    SCOPED_TRACE(ag::to_string(dtype));
    const Tensor x = iota({2, 3, 4}, dtype);
    // out[k][j][i] = x[i][j][k] = 12 i + 4 j + k
    std::vector<double> expected02;
    for (int k = 0; k < 4; ++k)
      for (int j = 0; j < 3; ++j)
        for (int i = 0; i < 2; ++i) expected02.push_back(12 * i + 4 * j + k);
    expect_values(ag::transpose(x, 0, 2), {4, 3, 2}, expected02);
    // out[i][k][j] = x[i][j][k]
    std::vector<double> expected12;
    for (int i = 0; i < 2; ++i)
      for (int k = 0; k < 4; ++k)
        for (int j = 0; j < 3; ++j) expected12.push_back(12 * i + 4 * j + k);
    expect_values(ag::transpose(x, 1, -1), {2, 4, 3}, expected12);
  }
}

TEST(Transpose, GradcheckAndGradgradcheck) {
  std::uint64_t seed = 10;
  struct Case {
    Shape shape;
    std::int64_t d0, d1;
  };
  for (const Case& c :
       {Case{{2, 3}, 0, 1}, Case{{4, 1}, 1, 0}, Case{{2, 3, 4}, 0, 2}, Case{{2, 3, 4}, 1, -1}, Case{{2, 3, 4}, 0, 1}}) {
    SCOPED_TRACE(ag::to_string(c.shape) + " " + std::to_string(c.d0) + "," + std::to_string(c.d1));
    auto f = [c](const Inputs& in) { return ag::transpose(in[0], c.d0, c.d1); };
    expect_grad_and_gradgrad("transpose", f, {randn64(c.shape, seed++)});
  }
  expect_gradcheck("t", [](const Inputs& in) { return in[0].t(); }, {randn64({3, 2}, seed++)});
}

TEST(Transpose, BadDimNamesOp) {
  expect_throw_with([] { ag::transpose(ag::ones({2, 3}), 0, 2); }, {"transpose"});
  expect_throw_with([] { ag::transpose(ag::ones({2, 3}), -3, 0); }, {"transpose"});
}

// ----- expand and sum_to -----

TEST(Expand, Forward) {
  for (Dtype dtype : kBothDtypes) {
    SCOPED_TRACE(ag::to_string(dtype));
    expect_values(ag::expand(tensor({1, 2, 3}, {3}, dtype), {2, 3}), {2, 3}, {1, 2, 3, 1, 2, 3});
    expect_values(ag::expand(tensor({1, 2}, {2, 1}, dtype), {2, 3}), {2, 3}, {1, 1, 1, 2, 2, 2});
    expect_values(ag::expand(tensor({7}, {}, dtype), {2, 2}), {2, 2}, {7, 7, 7, 7});
    expect_values(ag::expand(tensor({1, 2}, {2}, dtype), {2}), {2}, {1, 2});
    const Tensor x = tensor({1, 2, 3}, {1, 3, 1}, dtype);
    const Tensor y = ag::expand(x, {2, 3, 4});
    std::vector<double> expected;
    for (int i = 0; i < 2; ++i)
      for (int j = 0; j < 3; ++j)
        for (int k = 0; k < 4; ++k) expected.push_back(j + 1);
    expect_values(y, {2, 3, 4}, expected);
    // The result is a copy: writing to it leaves the source alone.
    const Tensor src = tensor({1, 2, 3}, {3}, dtype);
    Tensor e = ag::expand(src, {2, 3});
    e.fill_(0);
    EXPECT_EQ(src.at(0), 1.0);
  }
}

TEST(Expand, GradcheckAndGradgradcheck) {
  std::uint64_t seed = 20;
  for (const auto& [from, target] : std::vector<std::pair<Shape, Shape>>{
           {{3}, {2, 3}}, {{2, 1}, {2, 3}}, {{}, {2, 2}}, {{1, 3, 1}, {2, 3, 4}}, {{2, 3}, {2, 3}}, {{1}, {3}}}) {
    SCOPED_TRACE(ag::to_string(from) + " -> " + ag::to_string(target));
    const Shape to = target;  // a copy the lambdas can capture
    auto f = [to](const Inputs& in) { return ag::expand(in[0], to); };
    expect_grad_and_gradgrad("expand", f, {randn64(from, seed++)});
  }
}

TEST(Expand, IncompatibleShapeNamesOpAndShapes) {
  expect_throw_with([] { ag::expand(ag::ones({3}), {2, 4}); }, agtest::names("expand", {3}, {2, 4}));
  expect_throw_with([] { ag::expand(ag::ones({2, 3}), {3}); }, agtest::names("expand", {2, 3}, {3}));
  expect_throw_with([] { ag::expand(ag::ones({2, 1}), {3, 3}); }, agtest::names("expand", {2, 1}, {3, 3}));
}

TEST(SumTo, Forward) {
  for (Dtype dtype : kBothDtypes) {
    SCOPED_TRACE(ag::to_string(dtype));
    const Tensor x = iota({2, 3, 4}, dtype);  // x[i][j][k] = 12 i + 4 j + k
    expect_values(ag::sum_to(x, {3, 1}), {3, 1}, {60, 92, 124});
    expect_values(ag::sum_to(x, {4}), {4}, {60, 66, 72, 78});
    expect_values(ag::sum_to(x, {}), {}, {276});
    expect_values(ag::sum_to(x, {2, 1, 4}), {2, 1, 4}, {12, 15, 18, 21, 48, 51, 54, 57});
    expect_values(ag::sum_to(x, {2, 3, 4}), {2, 3, 4}, iota_values(24));
    expect_values(ag::sum_to(x, {1, 1, 1}), {1, 1, 1}, {276});
  }
}

TEST(SumTo, GradcheckAndGradgradcheck) {
  std::uint64_t seed = 30;
  for (const auto& [from, target] : std::vector<std::pair<Shape, Shape>>{
           {{2, 3, 4}, {3, 1}}, {{2, 3, 4}, {4}}, {{2, 3}, {}}, {{2, 3}, {2, 1}}, {{2, 3}, {2, 3}}, {{2, 3}, {1, 3}}}) {
    SCOPED_TRACE(ag::to_string(from) + " -> " + ag::to_string(target));
    const Shape to = target;  // a copy the lambdas can capture
    auto f = [to](const Inputs& in) { return ag::sum_to(in[0], to); };
    expect_grad_and_gradgrad("sum_to", f, {randn64(from, seed++)});
  }
}

TEST(SumTo, ShapeThatIsNotABroadcastSourceThrows) {
  expect_throw_with([] { ag::sum_to(ag::ones({2, 3}), {4}); }, agtest::names("sum_to", {2, 3}, {4}));
  expect_throw_with([] { ag::sum_to(ag::ones({2, 3}), {2, 2, 3}); }, {"sum_to"});
}

// ----- concat and stack -----

TEST(Concat, Forward) {
  for (Dtype dtype : kBothDtypes) {
    SCOPED_TRACE(ag::to_string(dtype));
    const Tensor a = tensor({1, 2, 3, 4, 5, 6}, {2, 3}, dtype);
    const Tensor b = tensor({7, 8, 9}, {1, 3}, dtype);
    expect_values(ag::concat({a, b}, 0), {3, 3}, {1, 2, 3, 4, 5, 6, 7, 8, 9});
    const Tensor c = tensor({10, 20}, {2, 1}, dtype);
    expect_values(ag::concat({a, c}, 1), {2, 4}, {1, 2, 3, 10, 4, 5, 6, 20});
    expect_values(ag::concat({c, a, c}, -1), {2, 5}, {10, 1, 2, 3, 10, 20, 4, 5, 6, 20});
    expect_values(ag::concat({a}, 0), {2, 3}, {1, 2, 3, 4, 5, 6});
    expect_values(ag::concat({tensor({1, 2}, {2}, dtype), tensor({3}, {1}, dtype)}, 0), {3}, {1, 2, 3});
    // 3-d along the middle dim.
    const Tensor x = iota({2, 1, 2}, dtype);  // [[[0,1]],[[2,3]]]
    const Tensor y = ag::add(iota({2, 2, 2}, dtype), 10.0);
    expect_values(ag::concat({x, y}, 1), {2, 3, 2}, {0, 1, 10, 11, 12, 13, 2, 3, 14, 15, 16, 17});
  }
}

TEST(Concat, GradcheckAndGradgradcheck) {
  auto cat = [](std::int64_t dim) { return [dim](const Inputs& in) { return ag::concat(in, dim); }; };
  expect_grad_and_gradgrad("concat", cat(0), {randn64({2, 3}, 1), randn64({1, 3}, 2), randn64({3, 3}, 3)});
  expect_grad_and_gradgrad("concat", cat(1), {randn64({2, 1}, 4), randn64({2, 3}, 5)});
  expect_grad_and_gradgrad("concat", cat(-1), {randn64({2, 2, 1}, 6), randn64({2, 2, 3}, 7)});
  expect_grad_and_gradgrad("concat", cat(1), {randn64({2, 1, 2}, 8), randn64({2, 2, 2}, 9)});
  expect_grad_and_gradgrad("concat", cat(0), {randn64({4}, 10)});
  // One input without grad.
  expect_gradcheck("concat", cat(0), {randn64({2, 3}, 11), randn64({1, 3}, 12, false)});
}

TEST(Concat, Errors) {
  expect_throw_with(
      [] {
        ag::concat({ag::ones({2, 3}), ag::ones({2, 4})}, 0);
      },
      agtest::names("concat", {2, 3}, {2, 4}));
  expect_throw_with([] { ag::concat({ag::ones({2, 3}), ag::ones({3})}, 0); }, agtest::names("concat", {2, 3}, {3}));
  expect_throw_with([] { ag::concat({ag::ones({2, 3}), ag::ones({2, 3})}, 2); }, {"concat"});
  expect_throw_with([] { ag::concat({}, 0); }, {"concat"});
  expect_throw_with([] { ag::concat({ag::ones({2, 3}, kF32), ag::ones({2, 3}, kF64)}, 0); }, {"concat"});
}

TEST(Stack, Forward) {
  for (Dtype dtype : kBothDtypes) {
    SCOPED_TRACE(ag::to_string(dtype));
    const Tensor a = tensor({1, 2, 3, 4}, {2, 2}, dtype);
    const Tensor b = tensor({5, 6, 7, 8}, {2, 2}, dtype);
    expect_values(ag::stack({a, b}, 0), {2, 2, 2}, {1, 2, 3, 4, 5, 6, 7, 8});
    expect_values(ag::stack({a, b}, 1), {2, 2, 2}, {1, 2, 5, 6, 3, 4, 7, 8});
    expect_values(ag::stack({a, b}, 2), {2, 2, 2}, {1, 5, 2, 6, 3, 7, 4, 8});
    expect_values(ag::stack({a, b}, -1), {2, 2, 2}, {1, 5, 2, 6, 3, 7, 4, 8});
    expect_values(ag::stack({tensor({1}, {}, dtype), tensor({2}, {}, dtype), tensor({3}, {}, dtype)}, 0), {3},
                  {1, 2, 3});
    expect_values(ag::stack({a}, 0), {1, 2, 2}, {1, 2, 3, 4});
  }
}

TEST(Stack, GradcheckAndGradgradcheck) {
  auto st = [](std::int64_t dim) { return [dim](const Inputs& in) { return ag::stack(in, dim); }; };
  const Inputs three = {randn64({2, 3}, 1), randn64({2, 3}, 2), randn64({2, 3}, 3)};
  for (std::int64_t dim : {0, 1, 2, -1}) {
    SCOPED_TRACE("dim " + std::to_string(dim));
    expect_grad_and_gradgrad("stack", st(dim), three);
  }
  expect_grad_and_gradgrad("stack", st(0), {randn64({}, 4), randn64({}, 5)});
  expect_gradcheck("stack", st(1), {randn64({3}, 6, false), randn64({3}, 7)});
}

TEST(Stack, Errors) {
  expect_throw_with([] { ag::stack({ag::ones({2, 3}), ag::ones({3, 2})}, 0); }, agtest::names("stack", {2, 3}, {3, 2}));
  expect_throw_with([] { ag::stack({ag::ones({2, 3}), ag::ones({2, 3})}, 3); }, {"stack"});
  expect_throw_with([] { ag::stack({}, 0); }, {"stack"});
}

// ----- narrow / slice -----

TEST(Narrow, Forward) {
  for (Dtype dtype : kBothDtypes) {
    SCOPED_TRACE(ag::to_string(dtype));
    const Tensor x = iota({4, 3}, dtype);  // rows [0,1,2] [3,4,5] [6,7,8] [9,10,11]
    expect_values(ag::narrow(x, 0, 1, 2), {2, 3}, {3, 4, 5, 6, 7, 8});
    expect_values(ag::narrow(x, 1, 2, 1), {4, 1}, {2, 5, 8, 11});
    expect_values(ag::narrow(x, -1, 0, 2), {4, 2}, {0, 1, 3, 4, 6, 7, 9, 10});
    expect_values(ag::narrow(x, 0, 0, 4), {4, 3}, iota_values(12));
    expect_values(ag::slice(x, 0, 3, 4), {1, 3}, {9, 10, 11});
    expect_values(ag::slice(x, 1, 1, 3), {4, 2}, {1, 2, 4, 5, 7, 8, 10, 11});
    const Tensor y = iota({2, 3, 4}, dtype);
    expect_values(ag::narrow(y, 1, 1, 1), {2, 1, 4}, {4, 5, 6, 7, 16, 17, 18, 19});
    expect_values(ag::narrow(y, 2, 3, 1), {2, 3, 1}, {3, 7, 11, 15, 19, 23});
  }
}

TEST(Narrow, GradcheckAndGradgradcheck) {
  struct Case {
    Shape shape;
    std::int64_t dim, start, length;
  };
  std::uint64_t seed = 40;
  for (const Case& c : {Case{{4, 3}, 0, 1, 2}, Case{{4, 3}, 1, 2, 1}, Case{{4, 3}, -1, 0, 2}, Case{{2, 3, 4}, 1, 1, 2},
                        Case{{2, 3, 4}, 2, 3, 1}, Case{{5}, 0, 0, 5}}) {
    SCOPED_TRACE(ag::to_string(c.shape) + " dim " + std::to_string(c.dim));
    auto f = [c](const Inputs& in) { return ag::narrow(in[0], c.dim, c.start, c.length); };
    expect_grad_and_gradgrad("narrow", f, {randn64(c.shape, seed++)});
  }
  expect_gradcheck("slice", [](const Inputs& in) { return ag::slice(in[0], 1, 1, 3); }, {randn64({3, 4}, seed++)});
}

TEST(Narrow, OutOfRangeNamesOp) {
  const Tensor x = ag::ones({4, 3});
  expect_throw_with([&] { ag::narrow(x, 0, 3, 2); }, {"narrow"});
  expect_throw_with([&] { ag::narrow(x, 1, 0, 4); }, {"narrow"});
  expect_throw_with([&] { ag::narrow(x, 0, 5, 0); }, {"narrow"});
  expect_throw_with([&] { ag::narrow(x, 0, 1, -1); }, {"narrow"});
  expect_throw_with([&] { ag::narrow(x, 2, 0, 1); }, {"narrow"});
  EXPECT_THROW(ag::slice(x, 0, 2, 5), std::exception);
}

// ----- index_select / index_add -----

TEST(IndexSelect, Forward) {
  for (Dtype dtype : kBothDtypes) {
    SCOPED_TRACE(ag::to_string(dtype));
    const Tensor x = iota({4, 3}, dtype);
    expect_values(ag::index_select(x, {3, 0, 3}), {3, 3}, {9, 10, 11, 0, 1, 2, 9, 10, 11});
    expect_values(ag::index_select(x, {1}), {1, 3}, {3, 4, 5});
    expect_values(ag::index_select(iota({3}, dtype), {2, 2, 0, 1}), {4}, {2, 2, 0, 1});
    expect_values(ag::index_select(iota({3, 2, 2}, dtype), {2, 0}), {2, 2, 2}, {8, 9, 10, 11, 0, 1, 2, 3});
  }
}

TEST(IndexSelect, GradientAccumulatesOverRepeatedIndices) {
  const Tensor x = tensor({1, 2, 3, 4, 5, 6}, {3, 2}, kF64, true);
  ag::sum(ag::index_select(x, {2, 0, 2, 2})).backward();
  expect_values(x.grad(), {3, 2}, {1, 1, 0, 0, 3, 3});
}

TEST(IndexSelect, GradcheckAndGradgradcheck) {
  expect_grad_and_gradgrad("index_select",
                           [](const Inputs& in) {
                             return ag::index_select(in[0], {2, 0, 2});
                           },
                           {randn64({4, 3}, 1)});
  expect_grad_and_gradgrad("index_select",
                           [](const Inputs& in) {
                             return ag::index_select(in[0], {1, 1, 0, 4});
                           },
                           {randn64({5}, 2)});
  expect_grad_and_gradgrad("index_select", [](const Inputs& in) { return ag::index_select(in[0], {1}); },
                           {randn64({2, 3, 2}, 3)});
}

TEST(IndexSelect, IndexOutOfRangeNamesOp) {
  const Tensor x = ag::ones({4, 3});
  expect_throw_with([&] { ag::index_select(x, {0, 4}); }, {"index_select", "4"});
  expect_throw_with([&] { ag::index_select(x, {100}); }, {"index_select"});
  expect_throw_with([&] { ag::index_select(ag::ones({}), {0}); }, {"index_select"});
}

TEST(IndexAdd, Forward) {
  for (Dtype dtype : kBothDtypes) {
    SCOPED_TRACE(ag::to_string(dtype));
    const Tensor src = tensor({1, 2, 3, 4, 5, 6}, {3, 2}, dtype);
    expect_values(ag::index_add(src, {1, 0, 1}, 3), {3, 2}, {3, 4, 6, 8, 0, 0});
    expect_values(ag::index_add(tensor({1, 2, 3}, {3}, dtype), {2, 2, 0}, 4), {4}, {3, 0, 3, 0});
    const Tensor src3 = iota({2, 2, 2}, dtype);
    expect_values(ag::index_add(src3, {0, 0}, 1), {1, 2, 2}, {4, 6, 8, 10});
  }
}

TEST(IndexAdd, IsTheAdjointOfIndexSelect) {
  // <index_select(x, idx), y> == <x, index_add(y, idx, rows)>
  const std::vector<std::int64_t> idx = {3, 1, 3, 0};
  const Tensor x = randn64({4, 3}, 1, false);
  const Tensor y = randn64({4, 3}, 2, false);
  const double lhs = ag::sum(ag::index_select(x, idx) * y).item();
  const double rhs = ag::sum(x * ag::index_add(y, idx, 4)).item();
  EXPECT_NEAR(lhs, rhs, 1e-12);
}

TEST(IndexAdd, GradcheckAndGradgradcheck) {
  expect_grad_and_gradgrad("index_add",
                           [](const Inputs& in) {
                             return ag::index_add(in[0], {1, 0, 1}, 3);
                           },
                           {randn64({3, 2}, 1)});
  expect_grad_and_gradgrad("index_add",
                           [](const Inputs& in) {
                             return ag::index_add(in[0], {4, 4, 0}, 5);
                           },
                           {randn64({3}, 2)});
  expect_grad_and_gradgrad("index_add",
                           [](const Inputs& in) {
                             return ag::index_add(in[0], {1, 0}, 2);
                           },
                           {randn64({2, 2, 3}, 3)});
}

TEST(IndexAdd, Errors) {
  const Tensor src = ag::ones({3, 2});
  expect_throw_with([&] { ag::index_add(src, {0, 1, 3}, 3); }, {"index_add"});
  expect_throw_with([&] { ag::index_add(src, {0, 1}, 3); }, {"index_add"});
  expect_throw_with([&] { ag::index_add(src, {0, -1, 1}, 3); }, {"index_add"});
}

// ----- a composite of shape ops with a non-linear op, second order -----

TEST(ShapeOps, CompositeGradgradcheck) {
  auto f = [](const Inputs& in) {
    const Tensor both = ag::concat({in[0], ag::transpose(in[1], 0, 1)}, 0);  // [2,3] + [3,2]^T -> [4,3]
    const Tensor picked = ag::index_select(ag::narrow(both, 1, 1, 2), {3, 0, 1});
    return ag::sum_to(ag::expand(ag::square(picked), {2, 3, 2}), {3, 1}).reshape({3});
  };
  expect_grad_and_gradgrad("shape composite", f, {randn64({2, 3}, 1), randn64({3, 2}, 2)});
}

}  // namespace
