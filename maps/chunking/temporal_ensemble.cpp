#include "maps/chunking/temporal_ensemble.h"

#include <cmath>
#include <stdexcept>
#include <string>

namespace maps::chunking {

TemporalEnsemble::TemporalEnsemble(double m) : m_(m) {
  if (!(m >= 0.0) || !std::isfinite(m))
    throw std::invalid_argument("TemporalEnsemble: the weight exponent m must be finite and >= 0, got " +
                                std::to_string(m));
}

void TemporalEnsemble::add(std::int64_t t, const Eigen::MatrixXd& chunk) {
  if (chunk.rows() < 1 || chunk.cols() < 1) throw std::invalid_argument("TemporalEnsemble::add: an empty chunk");
  if (!chunks_.empty() && (t <= chunks_.back().start || chunk.cols() != chunks_.back().actions.cols()))
    throw std::invalid_argument("TemporalEnsemble::add: chunk at step " + std::to_string(t) + " after one at step " +
                                std::to_string(chunks_.back().start) + " (steps must grow, action sizes agree)");
  chunks_.push_back({t, chunk});
}

Eigen::VectorXd TemporalEnsemble::action(std::int64_t t) {
  // Chunks that end before t can never vote again.
  while (!chunks_.empty() && chunks_.front().start + chunks_.front().actions.rows() <= t) chunks_.pop_front();
  Eigen::VectorXd sum;
  double total = 0.0;
  int i = 0;  // 0: the oldest chunk covering t
  for (const Chunk& c : chunks_) {
    if (c.start > t) break;
    const double weight = std::exp(-m_ * i++);
    const Eigen::VectorXd vote = c.actions.row(t - c.start).transpose();
    sum = sum.size() == 0 ? Eigen::VectorXd(weight * vote) : Eigen::VectorXd(sum + weight * vote);
    total += weight;
  }
  if (total == 0.0) throw std::invalid_argument("TemporalEnsemble::action: no chunk covers step " + std::to_string(t));
  return sum / total;
}

OpenLoop::OpenLoop(std::int64_t execute) : execute_(execute) {
  if (execute < 1)
    throw std::invalid_argument("OpenLoop: at least one action of a chunk must be executed, got " +
                                std::to_string(execute));
}

void OpenLoop::add(const Eigen::MatrixXd& chunk) {
  if (chunk.rows() < 1 || chunk.cols() < 1) throw std::invalid_argument("OpenLoop::add: an empty chunk");
  chunk_ = chunk;
  used_ = 0;
  limit_ = std::min<std::int64_t>(execute_, chunk.rows());
}

Eigen::VectorXd OpenLoop::action() {
  if (needs_chunk()) throw std::logic_error("OpenLoop::action: the chunk is spent; add the next one first");
  return chunk_.row(used_++).transpose();
}

}  // namespace maps::chunking
