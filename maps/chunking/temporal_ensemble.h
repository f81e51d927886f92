#pragma once

// Executing predicted action chunks (issue 46, item 2): ACT's temporal ensembling (Zhao et al., RSS 2023:
// imitate_episodes.py with --temporal_agg) and open-loop execution, per episode.

#include <Eigen/Core>
#include <cstdint>
#include <deque>

namespace maps::chunking {

// Every chunk predicted so far that covers step t votes for its action at t, weighted exp(-m i) with i = 0 the
// oldest such chunk, the weights normalised to sum 1 (ACT's rule, m = 0.01 there). Chunks are added in time order,
// one per step or fewer.
class TemporalEnsemble {
 public:
  explicit TemporalEnsemble(double m = 0.01);
  // A chunk [H, action size] predicted at step t (its row j is the action for step t + j).
  void add(std::int64_t t, const Eigen::MatrixXd& chunk);
  // The ensembled action for step t; throws when no chunk covers t.
  Eigen::VectorXd action(std::int64_t t);
  void reset() { chunks_.clear(); }

 private:
  struct Chunk {
    std::int64_t start;
    Eigen::MatrixXd actions;
  };
  double m_;
  std::deque<Chunk> chunks_;
};

// Open loop: a chunk is predicted when the last one's first `execute` actions are spent (Diffusion Policy's receding
// horizon: predict H, execute n_action_steps), and its actions are taken in order.
class OpenLoop {
 public:
  explicit OpenLoop(std::int64_t execute);
  // Whether the policy must predict a new chunk before acting.
  bool needs_chunk() const { return used_ >= limit_; }
  // The next chunk [H, action size]; its first min(execute, H) rows are executed.
  void add(const Eigen::MatrixXd& chunk);
  Eigen::VectorXd action();
  void reset() { used_ = limit_ = 0; }

 private:
  std::int64_t execute_;
  Eigen::MatrixXd chunk_;
  std::int64_t used_ = 0, limit_ = 0;
};

}  // namespace maps::chunking
