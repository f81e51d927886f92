#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <deque>
#include <functional>
#include <iosfwd>
#include <memory>
#include <nlohmann/json.hpp>
#include <random>
#include <string>
#include <vector>

#include "envs/env.h"
#include "envs/expert_policy.h"
#include "maps/rl/actor_critic.h"
#include "maps/rl/ppo_update_config.h"
#include "maps/rl/running_mean_std.h"

// PPO (clipped surrogate, GAE) on one env, with the recipe of issue 3 as defaults: 2048 steps per rollout,
// 10 epochs of minibatches of 64, clip 0.2, GAE(0.99, 0.95) bootstrapped at the time limit, Adam 3e-4 (eps
// 1e-5) annealed linearly to 0, advantages normalised per minibatch, value loss 0.5 * mean((V - R)^2)
// (unclipped, SB3's weighting), no entropy bonus, gradient-norm clip 0.5 over all parameters, observations
// normalised by running mean/std (clip 10), rewards scaled by the running std of the discounted return.
namespace maps::rl {

struct PPOConfig : PPOUpdateConfig {
  std::int64_t total_steps = 1'000'000;  // env steps; the learning rate reaches 0 here
  int steps_per_rollout = 2048;
  int minibatch_size = 64;
  bool normalize_observations = true;
  bool scale_rewards = true;
  std::vector<std::int64_t> hidden = {64, 64};
  std::uint64_t seed = 0;
  int checkpoint_every = 10;  // iterations between checkpoints (a checkpoint is also written at the end)
  int recent_episodes = 10;   // the progress line's mean return is over this many finished episodes
  // When >= 0, observation[pitch_index] is a torso pitch (HalfCheetah: 1) and each iteration reports the fraction
  // of its rollout's steps spent turned over (cos(pitch) < 0), to catch a policy learning to run on its back.
  int pitch_index = -1;
  // When > 0 (needs pitch_index): a training episode ends as terminated (no bootstrap, so the value of what follows
  // is 0) at the first step whose pitch, wrapped to [-pi, pi], exceeds this angle in magnitude (radians, < pi;
  // pi/2: turned over; less: tilted too far to recover). On HalfCheetah, where running earns positive reward and
  // the value estimate is positive, that makes tilting over cost the rest of the episode's return, instead of
  // leaving it to luck whether a seed avoids it; early in a cold start, when returns are still negative, ending
  // early can pay, so use it to fine-tune or warm-start. With an angle <= pi/2 no action is ever taken turned over,
  // so PPOIterationStats::flipped_fraction stays 0; the progress line's return then averages the cut episodes.
  double end_episode_at_pitch = 0.0;
};

// What one iteration (a rollout then its updates) measured.
struct PPOIterationStats {
  std::int64_t iteration = 0;  // 1-based
  std::int64_t steps = 0;      // env steps done after this iteration
  double recent_return = 0.0;  // mean raw return of the last finished episodes (NaN before the first)
  int episodes_finished = 0;   // in this iteration's rollout
  double learning_rate = 0.0;
  double policy_loss = 0.0;  // means over every minibatch of every epoch (as SB3 logs them)
  double value_loss = 0.0;
  double entropy = 0.0;
  double approx_kl = 0.0;  // mean of (r - 1) - log r, before each minibatch's update
  double clip_fraction = 0.0;
  double fps = 0.0;               // env steps per second of this iteration (rollout and update)
  double flipped_fraction = 0.0;  // of this rollout's steps (0 unless PPOConfig::pitch_index >= 0)
};

// Trains an ActorCritic on `env`. With a non-empty `out_dir`, a checkpoint (out_dir/checkpoint.ckpt, written
// atomically) holds the model, the Adam moments, the normalisers, the step count, the RNG state and the state
// of the episode in progress (its seed and the actions taken so far, replayed on resume: envs are
// deterministic given seed and actions), so a resumed run continues exactly as an uninterrupted one would.
// train() resumes from an existing checkpoint by itself. A non-finite loss or gradient norm throws
// std::runtime_error, leaving the last good checkpoint in place.
class PPOTrainer {
 public:
  // `log` receives one progress line per iteration (nullptr: silent).
  PPOTrainer(envs::Env& env, const PPOConfig& config, std::string out_dir = "", std::ostream* log = nullptr);

  // Runs iterations until total_steps (or `max_iterations` more iterations, when >= 0), checkpointing every
  // checkpoint_every iterations and when it stops. Returns the number of iterations run.
  int train(int max_iterations = -1);

  // Called after every iteration (after its checkpoint, if any); returning false stops train() early (a
  // checkpoint is written), e.g. to abandon a run whose policy flipped over.
  void set_iteration_callback(std::function<bool(const PPOIterationStats&)> callback) {
    callback_ = std::move(callback);
  }

  // Loads out_dir's checkpoint if there is one (train() calls it once); returns whether it did.
  bool resume();
  // Warm start: copies the model weights and both normalisers' statistics from another run's checkpoint (say, an
  // upright expert of a neighbouring task); the optimiser, step count and RNG start afresh. Call before train(),
  // typically when resume() found nothing. The architecture must match.
  void warm_start_from(const std::string& checkpoint_path);
  // Writes the checkpoint now (no-op without out_dir).
  void save_checkpoint() const;
  std::string checkpoint_path() const;

  ActorCritic& model() { return *model_; }
  const std::shared_ptr<ActorCritic>& model_ptr() const { return model_; }
  const RunningMeanStd& observation_stats() const { return obs_rms_; }
  std::int64_t steps_done() const { return steps_done_; }
  std::int64_t iterations_done() const { return iteration_; }
  std::int64_t total_iterations() const;
  const std::vector<PPOIterationStats>& history() const { return history_; }
  double recent_mean_return() const;
  const PPOConfig& config() const { return config_; }

 private:
  struct Rollout;
  void start_episode();
  void collect(Rollout& rollout);
  PPOIterationStats update(const Rollout& rollout, double learning_rate);
  void adam_step(double learning_rate);
  std::string state_text() const;
  // Loads model, Adam moments (when `with_optimizer`) and normaliser statistics; returns the state text's JSON.
  std::string load_tensors_from(const std::string& path, bool with_optimizer);
  void load_state_text(const std::string& text);
  void check_same_recipe(const std::string& path, const nlohmann::json& saved_config) const;

  envs::Env& env_;
  PPOConfig config_;
  std::string out_dir_;
  std::ostream* log_;
  std::shared_ptr<ActorCritic> model_;
  std::vector<ag::Tensor> params_;
  std::vector<ag::Tensor> adam_m_, adam_v_;
  std::int64_t adam_t_ = 0;
  RunningMeanStd obs_rms_;
  RewardScaler reward_scaler_;
  ag::Generator rng_;  // action noise and minibatch shuffles
  double end_cos_;     // cos(config.end_episode_at_pitch)

  std::int64_t steps_done_ = 0;
  std::int64_t iteration_ = 0;
  bool resume_checked_ = false;

  // The episode in progress.
  std::int64_t episode_index_ = 0;  // episodes started so far; the next episode's seed derives from it
  std::uint64_t episode_seed_ = 0;
  std::vector<Eigen::VectorXd> episode_actions_;
  double episode_return_ = 0.0;
  Eigen::VectorXd current_obs_;  // raw
  bool episode_active_ = false;
  std::deque<double> recent_returns_;
  std::vector<PPOIterationStats> history_;
  std::function<bool(const PPOIterationStats&)> callback_;
};

// The seed of the k-th training episode of a run seeded `seed` (a splitmix64 mix; disjoint from small seeds
// used for evaluation only by chance, so evaluate with seeds of your own range).
std::uint64_t training_episode_seed(std::uint64_t seed, std::int64_t episode);

// The trained policy as a plain-Eigen expert: the policy MLP's weights ([out, in]) and biases, log_std, and the
// observation normaliser's mean, var, clip and epsilon.
envs::ExpertPolicy export_expert(const ActorCritic& model, const RunningMeanStd& obs_stats, const std::string& task,
                                 const std::string& metadata_json = "{}");

// Returns of `episodes` episodes from seeds first_seed, first_seed + 1, ..., acting with the mean action
// (clipped to the env's bounds). `pitches`, when given, receives observation[pitch_index] of every step of every
// episode (one vector per episode), for the upright check.
std::vector<double> evaluate_policy(envs::Env& env, ActorCritic& model, const RunningMeanStd& obs_stats, int episodes,
                                    std::uint64_t first_seed, std::vector<std::vector<double>>* pitches = nullptr,
                                    int pitch_index = 1);

}  // namespace maps::rl
