#pragma once

// What the diffusion tests share: seeded standard-normal float64 tensors.

#include <cstdint>

#include "autograd/autograd.h"

namespace diffusiontest {

inline maps::ag::Tensor randn64(const maps::ag::Shape& shape, std::uint64_t seed) {
  maps::ag::Generator gen(seed);
  return maps::ag::randn(shape, gen, maps::ag::Dtype::Float64);
}

}  // namespace diffusiontest
