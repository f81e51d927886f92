#pragma once

#include <cstdint>

namespace maps::experiments {

// `maps demo`: trains a small tanh MLP on a synthetic regression with the autograd engine and
// prints the loss falling.
struct DemoOptions {
  int steps = 500;         // optimiser steps (full batch)
  std::uint64_t seed = 0;  // seeds the data and the initial weights
  int hidden = 32;         // hidden width of the 2-layer MLP
  double lr = 0.01;        // Adam learning rate
  int log_every = 50;      // print the loss every this many steps
  int samples = 256;       // size of the synthetic data set
};

// Returns 0 when the final loss is below the initial loss, 1 otherwise.
int run_demo(const DemoOptions& options);

}  // namespace maps::experiments
