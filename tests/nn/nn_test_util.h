#pragma once

// Shared helpers of the nn tests.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <exception>
#include <string>
#include <vector>

#include "nn/nn.h"
#include "tests/common/error_of.h"
#include "tests/common/max_abs_diff.h"

namespace nntest {

namespace ag = maps::ag;
namespace nn = maps::nn;
namespace optim = maps::optim;
using ag::Dtype;
using ag::Shape;
using ag::Tensor;
using ::testing::HasSubstr;

using ::error_of;

inline Tensor tensor(const std::vector<double>& values, const Shape& shape, Dtype dtype = Dtype::Float64) {
  return ag::from_vector(values, shape, dtype);
}

using ::max_abs_diff;

inline std::vector<std::string> names_of(const nn::NamedTensors& tensors) {
  std::vector<std::string> names;
  for (const auto& t : tensors) names.push_back(t.name);
  return names;
}

}  // namespace nntest
