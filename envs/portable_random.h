#pragma once

#include <cstdint>

// Random numbers that are the same on every platform and standard library (std::uniform_int_distribution and
// std::shuffle are implementation-defined), for everything a seed must reproduce: data splits, demo draws.
namespace maps::envs {

// splitmix64's output function of one state: a well-mixed 64-bit hash of x.
inline std::uint64_t splitmix64(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

// The splitmix64 generator: splitmix64(seed), splitmix64(seed + golden), ...
struct SplitMix64 {
  std::uint64_t state;
  std::uint64_t operator()() {
    const std::uint64_t out = splitmix64(state);
    state += 0x9e3779b97f4a7c15ULL;
    return out;
  }
};

// Uniform in [0, n) by rejection from a generator of uniform 64-bit words (std::mt19937_64, SplitMix64).
template <typename Generator>
std::uint64_t draw_below(Generator& gen, std::uint64_t n) {
  const std::uint64_t limit = UINT64_MAX - UINT64_MAX % n;  // accept draws below a multiple of n
  std::uint64_t x;
  do x = gen();
  while (x >= limit);
  return x % n;
}

}  // namespace maps::envs
