// reach: bring the fingertips within 5 cm of a goal in the air; a puck stands on the table as a distractor.

#include <memory>

#include "envs/mt10/puck_env.h"
#include "envs/mt10/tasks.h"

namespace maps::envs::mt10 {
namespace {

class ReachEnv : public PuckEnv {
 public:
  ReachEnv(const std::string& task, std::int64_t index, MT10Options options) : PuckEnv(task, index, options) {}

  bool is_success() const override { return (tcp_center() - goal()).norm() <= 0.05; }

 protected:
  void place_objects(std::mt19937_64& rng) override { set_goal(place_puck_and_draw_goal(rng, 0.05, 0.3)); }
};

std::unique_ptr<MT10Env> make_reach(const std::string& task, std::int64_t index, MT10Options options) {
  return std::make_unique<ReachEnv>(task, index, options);
}

Eigen::Vector4d reach_expert(const Eigen::VectorXd& obs) {
  return expert_action(move_toward(obs_hand(obs), obs_goal(obs), 5.0), 0.0);
}

const MT10TaskRegistration reach_registration({"reach", 0, make_reach, reach_expert, 1.0});

}  // namespace

}  // namespace maps::envs::mt10
