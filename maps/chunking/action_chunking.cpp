#include "maps/chunking/action_chunking.h"

#include <cmath>
#include <stdexcept>

namespace maps::chunking {

const std::vector<std::string>& execution_names() {
  static const std::vector<std::string> names{"ensemble", "open_loop"};
  return names;
}

void check_action_chunking(const ActionChunking& c, const std::string& key) {
  if (c.horizon < 1 || c.horizon > 1000)
    throw std::invalid_argument("config " + key + ".horizon: expected 1 to 1000 actions per query, got " +
                                std::to_string(c.horizon));
  if (c.execution != "ensemble" && c.execution != "open_loop")
    throw std::invalid_argument("config " + key + ".execution: expected \"ensemble\" or \"open_loop\", got \"" +
                                c.execution + "\"");
  if (c.execute < 1 || c.execute > c.horizon)
    throw std::invalid_argument("config " + key + ".execute: expected 1 to the horizon (" + std::to_string(c.horizon) +
                                ") actions per chunk, got " + std::to_string(c.execute));
  if (!std::isfinite(c.ensemble_decay) || c.ensemble_decay < 0.0)
    throw std::invalid_argument("config " + key + ".ensemble_decay: expected a finite value >= 0, got " +
                                std::to_string(c.ensemble_decay));
}

ChunkExecutor::ChunkExecutor(const ActionChunking& chunking, std::int64_t action_size)
    : chunking_(chunking),
      action_size_(action_size),
      ensemble_(chunking.ensemble_decay),
      open_loop_(chunking.execution == "open_loop" ? chunking.execute : 1) {
  check_action_chunking(chunking, "chunking");
  if (action_size < 1) throw std::invalid_argument("chunk executor: action size must be >= 1");
}

bool ChunkExecutor::needs_chunk() const { return chunking_.execution == "ensemble" || open_loop_.needs_chunk(); }

void ChunkExecutor::add(const Eigen::Ref<const Eigen::VectorXd>& chunk) {
  if (chunk.size() != chunking_.horizon * action_size_)
    throw std::invalid_argument("chunk executor: a chunk of " + std::to_string(chunk.size()) + " values, expected " +
                                std::to_string(chunking_.horizon) + " x " + std::to_string(action_size_));
  // Time-major values: row j is the action for step + j.
  const Eigen::VectorXd values = chunk;
  const Eigen::MatrixXd rows = Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
      values.data(), chunking_.horizon, action_size_);
  if (chunking_.execution == "ensemble") {
    ensemble_.add(step_, rows);
  } else {
    open_loop_.add(rows);
  }
}

Eigen::VectorXd ChunkExecutor::action() {
  Eigen::VectorXd a = chunking_.execution == "ensemble" ? ensemble_.action(step_) : open_loop_.action();
  ++step_;
  return a;
}

}  // namespace maps::chunking
