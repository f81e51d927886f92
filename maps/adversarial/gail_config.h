#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "maps/adversarial/discriminator.h"
#include "maps/adversarial/discriminator_loss.h"
#include "maps/rl/ppo_update_config.h"

// A GAIL run's settings (the run config's "gail" section; docs/adversarial.md says where each default comes from).
namespace maps::adversarial {

// PPOUpdateConfig: the generator's PPO, the recipe of maps/rl/ppo.h (issue 3).
struct GailConfig : rl::PPOUpdateConfig {
  // Env steps per task the run may take (every task gets the same number of episodes per iteration). The PPO
  // learning rate anneals to 0 here.
  std::int64_t env_steps_per_task = 1'000'000;
  // Episodes per task per iteration, all tasks' episodes stepped in lockstep with one policy call per step.
  int rollout_episodes = 2;
  // Threads stepping the envs (and running ops): results do not depend on it.
  int threads = 1;

  std::int64_t minibatch_per_task = 64;  // rows of every task in a PPO minibatch (MAPS's selector losses want balance)
  std::vector<std::int64_t> critic_hidden = {64, 64};  // V(s, task): a tanh MLP on [s, one_hot(task)]
  double initial_log_std = 0.0;                        // the Gaussian head's state-independent log std, per action
  // Divide each task's rewards by the running std of its discounted return (ikostrikov's; SB3's VecNormalize).
  bool normalize_reward = true;
  std::string reward = "gail";  // gail_reward_kinds()

  DiscriminatorConfig discriminator;
  // The gradient penalty at ikostrikov's 10 and the warm-up below: in the pilot (docs/adversarial.md, A against B)
  // without them the discriminator won within ten iterations and the policy scored 0.26 of the expert's return after
  // 10^6 env steps, with them 0.93.
  DiscriminatorLossConfig discriminator_loss{10.0, 0.0};
  double discriminator_learning_rate = 3e-4;
  int discriminator_updates = 5;                    // Adam steps per iteration (ikostrikov's gail-epoch)
  std::int64_t discriminator_batch_per_task = 128;  // demonstration pairs per task per step, and as many policy pairs
  int discriminator_warmup_iterations = 10;         // the first iterations take discriminator_warmup_updates steps
  int discriminator_warmup_updates = 100;

  // A BC term beside the adversarial one: bc_weight times the method's own BC loss (with its regularisers) on a
  // balanced batch of bc_states_per_task demonstration states per task. 0: off.
  double bc_weight = 0.0;
  std::int64_t bc_states_per_task = 64;

  // best.ckpt: "last" (the policy after the last iteration) or "validation" (the iteration whose mean action error
  // on the validation demonstrations was lowest, the BC runs' rule; a GAIL policy is not trained to lower it).
  std::string checkpoint = "last";
  int checkpoint_every = 1;  // iterations between writes of last.ckpt (and at the end)
  // The validation states scored each iteration (evenly spaced through each task's validation demonstrations; the
  // run config's train.validation_states_per_task; 0: every validation state).
  std::int64_t validation_states_per_task = 2000;
};

// Throws std::invalid_argument naming the key ("config gail.clip: ...") for any value out of its range.
void check_gail_config(const GailConfig& config);

}  // namespace maps::adversarial
