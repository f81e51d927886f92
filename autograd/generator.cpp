#include "autograd/generator.h"

#include <cmath>

namespace maps::ag {

double Generator::uniform(double low, double high) {
  // 53 random bits: the same numbers on every standard library, unlike std::uniform_real_distribution.
  const double unit = static_cast<double>(engine_() >> 11) * 0x1.0p-53;
  return low + (high - low) * unit;
}

double Generator::normal() {
  // Box-Muller written out so that seeded tensors do not depend on the standard library's choice.
  double u1 = uniform();
  while (u1 <= 0.0) u1 = uniform();
  const double u2 = uniform();
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * M_PI * u2);
}

}  // namespace maps::ag
