#include "maps/rl/upright.h"

#include <cmath>

namespace maps::rl {

double flipped_fraction(const std::vector<double>& pitches) {
  if (pitches.empty()) return 0.0;
  std::size_t flipped = 0;
  for (double pitch : pitches)
    if (std::cos(pitch) < 0.0) ++flipped;
  return static_cast<double>(flipped) / static_cast<double>(pitches.size());
}

bool ran_flipped(const std::vector<double>& pitches, double max_flipped_fraction) {
  return flipped_fraction(pitches) > max_flipped_fraction;
}

}  // namespace maps::rl
