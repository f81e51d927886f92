// split_train_valid: the deterministic train/valid split of a demo file's demos (mask/train, mask/valid).

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <utility>

#include "envs/demo_file.h"
#include "envs/portable_random.h"

namespace maps::envs {

std::pair<std::vector<int>, std::vector<int>> split_train_valid(int n_demos, double train_fraction,
                                                                std::uint64_t seed) {
  if (n_demos < 0)
    throw std::invalid_argument("split_train_valid: n_demos must be >= 0, got " + std::to_string(n_demos));
  if (!(train_fraction > 0.0 && train_fraction < 1.0))
    throw std::invalid_argument("split_train_valid: train_fraction must be in (0, 1), got " +
                                std::to_string(train_fraction));
  // floor((1 - fraction) * n), with a little slack so that 0.3 * 10 = 3.0000000000000004 gives 3.
  int n_valid = static_cast<int>(std::floor((1.0 - train_fraction) * n_demos + 1e-9));
  if (n_demos >= 2) n_valid = std::clamp(n_valid, 1, n_demos - 1);
  if (n_demos < 2) n_valid = 0;

  // Fisher-Yates with splitmix64 and rejection sampling: the same permutation on every platform
  // (std::shuffle and std::uniform_int_distribution are implementation-defined).
  envs::SplitMix64 gen{seed};
  std::vector<int> order(static_cast<std::size_t>(n_demos));
  for (int i = 0; i < n_demos; ++i) order[static_cast<std::size_t>(i)] = i;
  for (int i = n_demos - 1; i > 0; --i) {
    const std::uint64_t r = draw_below(gen, static_cast<std::uint64_t>(i) + 1);
    std::swap(order[static_cast<std::size_t>(i)], order[static_cast<std::size_t>(r)]);
  }
  std::vector<int> valid(order.begin(), order.begin() + n_valid), train(order.begin() + n_valid, order.end());
  std::sort(train.begin(), train.end());
  std::sort(valid.begin(), valid.end());
  return {std::move(train), std::move(valid)};
}

}  // namespace maps::envs
