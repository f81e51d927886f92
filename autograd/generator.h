#pragma once

#include <cstdint>
#include <random>

namespace maps::ag {

// A seeded source of random numbers; the same seed gives the same tensors on every run.
class Generator {
 public:
  explicit Generator(std::uint64_t seed = 0) : engine_(seed) {}
  void seed(std::uint64_t seed) { engine_.seed(seed); }
  double uniform(double low = 0.0, double high = 1.0);
  double normal();
  std::uint64_t next_u64() { return engine_(); }
  std::mt19937_64& engine() { return engine_; }

 private:
  std::mt19937_64 engine_;
};

}  // namespace maps::ag
