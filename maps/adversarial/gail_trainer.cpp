#include "maps/adversarial/gail_trainer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <numeric>
#include <optional>
#include <ostream>
#include <random>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "autograd/parallel.h"
#include "envs/portable_random.h"
#include "envs/seed_ranges.h"
#include "maps/adversarial/discriminator_loss.h"
#include "maps/adversarial/gail_head.h"
#include "maps/adversarial/gail_rollout.h"
#include "maps/adversarial/gail_state.h"
#include "maps/rl/actor_critic.h"
#include "maps/rl/gae.h"
#include "maps/rl/running_mean_std.h"
#include "maps/training/checkpoint_record.h"
#include "maps/training/curve_file.h"
#include "maps/training/run_files.h"
#include "nn/clip_grad.h"
#include "nn/optim/adam.h"
#include "nn/serialize.h"

namespace maps::adversarial {
namespace fs = std::filesystem;
using Json = nlohmann::json;

namespace {

ag::Tensor rows_of(const ag::Tensor& matrix, const std::vector<std::int64_t>& rows) {
  return ag::index_select(matrix, rows);
}

ag::Tensor vector_tensor(const Eigen::VectorXd& values, const std::vector<std::int64_t>& rows) {
  std::vector<double> picked(rows.size());
  for (std::size_t j = 0; j < rows.size(); ++j) picked[j] = values(rows[j]);
  return ag::from_vector(picked, {static_cast<std::int64_t>(rows.size())});
}

// Fisher-Yates with portable draws (std::shuffle differs between standard libraries).
void shuffle(std::vector<std::int64_t>& rows, std::mt19937_64& rng) {
  for (std::size_t i = rows.size(); i > 1; --i) std::swap(rows[i - 1], rows[envs::draw_below(rng, i)]);
}

void check_finite(double value, const std::string& what, std::int64_t iteration) {
  if (!std::isfinite(value))
    throw std::runtime_error("GAIL iteration " + std::to_string(iteration) + ": " + what + " is not finite (" +
                             std::to_string(value) + "); last.ckpt holds the last good iteration");
}

// What one iteration measured, for curve.csv and the progress line.
struct IterationRecord {
  std::int64_t iteration = 0, env_steps_per_task = 0;
  std::vector<double> task_returns;  // mean env return of the rollout's episodes, per task
  double success = 0.0;              // share of the rollout's episodes with success at some step
  double discriminator_loss = 0.0, expert_accuracy = 0.0, policy_accuracy = 0.0, penalty = 0.0;
  double reward = 0.0;  // mean of the discriminator's reward per step, before normalisation
  double policy_loss = 0.0, value_loss = 0.0, entropy = 0.0, approx_kl = 0.0, clip_fraction = 0.0, bc = 0.0;
  std::vector<std::pair<std::string, double>> regularizer;  // the method's own terms, averaged over minibatches
  double validation_bc = 0.0, learning_rate = 0.0, env_steps_per_second = 0.0;
  std::optional<double> cpu_seconds;  // the iteration's process CPU time; none in a curve begun without the column
};

std::string curve_header(const IterationRecord& r, const std::vector<std::string>& task_names) {
  std::string header = "iteration,env_steps_per_task";
  for (const auto& name : task_names) header += ",return:" + name;
  header +=
      ",success,discriminator_loss,expert_accuracy,policy_accuracy,gradient_penalty,reward,policy_loss,"
      "value_loss,entropy,approx_kl,clip_fraction,bc";
  for (const auto& [name, value] : r.regularizer) header += "," + name;
  header += ",validation_bc,learning_rate,env_steps_per_second";
  if (r.cpu_seconds) header += ",cpu_seconds";
  return header;
}

std::string curve_row(const IterationRecord& r) {
  std::ostringstream row;
  row.precision(9);
  row << r.iteration << "," << r.env_steps_per_task;
  for (const double value : r.task_returns) row << "," << value;
  row << "," << r.success << "," << r.discriminator_loss << "," << r.expert_accuracy << "," << r.policy_accuracy << ","
      << r.penalty << "," << r.reward << "," << r.policy_loss << "," << r.value_loss << "," << r.entropy << ","
      << r.approx_kl << "," << r.clip_fraction << "," << r.bc;
  for (const auto& [name, value] : r.regularizer) row << "," << value;
  row << "," << r.validation_bc << "," << r.learning_rate << "," << r.env_steps_per_second;
  if (r.cpu_seconds) row << "," << *r.cpu_seconds;
  return row.str();
}

// Discriminator steps on the rollout's pairs against balanced demonstration batches.
void train_discriminator(Discriminator& discriminator, optim::Adam& adam, const core::DemoDataset& data,
                         const Rollout& rollout, const ag::Tensor& rollout_pairs, const GailConfig& config, int updates,
                         std::mt19937_64& rng, ag::Generator& gen, std::int64_t iteration, IterationRecord& record) {
  const std::int64_t per_task = config.discriminator_batch_per_task;
  const auto K = static_cast<std::int64_t>(data.num_tasks());
  double loss_sum = 0.0, expert_sum = 0.0, policy_sum = 0.0, penalty_sum = 0.0;
  for (int u = 0; u < updates; ++u) {
    const core::Batch expert = data.sample(per_task, rng, ag::Dtype::Float32);
    std::vector<std::int64_t> rows;
    rows.reserve(static_cast<std::size_t>(K * per_task));
    for (std::int64_t k = 0; k < K; ++k) {
      const auto& own = rollout.task_rows[static_cast<std::size_t>(k)];
      for (std::int64_t j = 0; j < per_task; ++j) rows.push_back(own[envs::draw_below(rng, own.size())]);
    }
    std::vector<double> mix(rows.size());
    for (double& m : mix) m = gen.uniform();
    const DiscriminatorLoss loss = discriminator_loss(
        discriminator, ag::concat({expert.observations, expert.actions}, 1), rows_of(rollout_pairs, rows), expert.tasks,
        config.discriminator_loss, ag::from_vector(mix, {static_cast<std::int64_t>(mix.size())}));
    const double total = loss.total.item();
    check_finite(total, "the discriminator's loss", iteration);
    discriminator.zero_grad();
    loss.total.backward();
    adam.step();
    loss_sum += loss.cross_entropy.item();
    expert_sum += loss.expert_accuracy;
    policy_sum += loss.policy_accuracy;
    if (loss.penalty.defined()) penalty_sum += loss.penalty.item();
  }
  discriminator.zero_grad();
  if (updates > 0) {
    record.discriminator_loss = loss_sum / updates;
    record.expert_accuracy = expert_sum / updates;
    record.policy_accuracy = policy_sum / updates;
    record.penalty = penalty_sum / updates;
  }
}

}  // namespace

std::uint64_t rollout_seed(std::uint64_t seed, std::int64_t task, std::int64_t episode) {
  // A hash of (seed, task), then consecutive episodes, folded into 2^50 seeds above kRolloutSeedBegin.
  const std::uint64_t z = envs::splitmix64(envs::splitmix64(seed) ^ static_cast<std::uint64_t>(task));
  constexpr std::uint64_t kSpan = 1ULL << 50;
  return envs::kRolloutSeedBegin + ((z + static_cast<std::uint64_t>(episode)) & (kSpan - 1));
}

GailSummary train_gail(core::Policy& policy, const core::DemoDataset& data, const core::EnvFactory& make_env,
                       const GailConfig& config, std::uint64_t seed, const std::string& run_dir, std::ostream* log,
                       std::int64_t max_iterations) {
  check_gail_config(config);
  if (run_dir.empty()) throw std::invalid_argument("train_gail: a run folder is needed");
  const auto wall_start = std::chrono::steady_clock::now();
  fs::create_directories(run_dir);
  const core::PolicyShape shape = policy.shape();
  const std::int64_t K = shape.num_tasks, S = shape.observation_size, A = shape.action_size;
  if (K != data.num_tasks() || S != data.observation_size() || A != data.action_size())
    throw std::invalid_argument("train_gail: the policy's shapes differ from the data's");
  const int previous_threads = ag::num_threads();
  ag::set_num_threads(config.threads);
  struct RestoreThreads {
    int threads;
    ~RestoreThreads() { ag::set_num_threads(threads); }
  } restore_threads{previous_threads};
  // A policy on raw inputs (MAPS's "raw_clipped") undoes the standardisation with these, as under BC (train_policy).
  policy.set_observation_statistics(data.standardizer().mean, data.standardizer().std);

  // Everything the run draws derives from its seed, each stream its own.
  ag::Generator init_gen(seed ^ 0x5A17A17ULL);
  GaussianCriticHead head(S, A, K, config.critic_hidden, config.initial_log_std, init_gen);
  Discriminator discriminator(config.discriminator, S, A, K, init_gen);
  std::mt19937_64 rng(seed ^ 0x6A11ULL);    // batches and shuffles
  ag::Generator noise(seed ^ 0xAC7105ULL);  // the actions' noise, the penalty's mixes

  std::vector<ag::Tensor> params;
  for (const ag::Tensor& p : policy.parameters())
    if (p.requires_grad()) params.push_back(p);
  for (const ag::Tensor& p : head.parameters()) params.push_back(p);
  optim::AdamOptions ppo_options;
  ppo_options.lr = config.learning_rate;
  ppo_options.eps = config.adam_eps;
  optim::Adam adam(params, ppo_options);
  optim::AdamOptions disc_options;
  disc_options.lr = config.discriminator_learning_rate;
  optim::Adam discriminator_adam(discriminator.parameters(), disc_options);
  std::vector<rl::RewardScaler> reward_scalers(static_cast<std::size_t>(K), rl::RewardScaler(config.gamma));

  const std::string last_path = (fs::path(run_dir) / core::run_files::kLastCheckpoint).string();
  const std::string best_path = (fs::path(run_dir) / core::run_files::kBestCheckpoint).string();
  const std::string curve_path = (fs::path(run_dir) / core::run_files::kCurve).string();
  GailState state;
  GailSummary summary;
  if (fs::exists(last_path)) {
    GailModules modules{policy, head, discriminator, adam, discriminator_adam, reward_scalers};
    state = load_gail_state(last_path, modules, rng, noise);
    summary.resumed = true;
    core::truncate_curve(curve_path, state.iteration);
  } else {
    std::ofstream(curve_path, std::ios::trunc);
  }

  // Envs of every task, rollout_episodes each, built once and reset with fresh seeds every iteration.
  std::vector<std::unique_ptr<envs::Env>> envs;
  std::vector<std::int64_t> env_tasks;
  for (std::int64_t k = 0; k < K; ++k)
    for (int e = 0; e < config.rollout_episodes; ++e) {
      envs.push_back(make_env(data.task_names()[static_cast<std::size_t>(k)]));
      env_tasks.push_back(k);
    }
  const core::Batch validation = data.validation_batch(ag::Dtype::Float32, config.validation_states_per_task);
  const double budget = static_cast<double>(config.env_steps_per_task);

  std::int64_t iterations_here = 0;
  bool header_written = fs::exists(curve_path) && fs::file_size(curve_path) > 0;
  // A curve begun by a build from before the column keeps its columns when resumed.
  const bool cpu_column = core::curve_has_cpu_column(curve_path);
  while (state.env_steps_per_task < config.env_steps_per_task &&
         (max_iterations < 0 || iterations_here < max_iterations)) {
    const std::int64_t iteration = state.iteration + 1;
    const auto iteration_start = std::chrono::steady_clock::now();
    const double iteration_cpu_start = core::process_cpu_seconds();
    IterationRecord record;
    record.iteration = iteration;
    record.learning_rate =
        config.anneal_learning_rate
            ? config.learning_rate * std::max(0.0, 1.0 - static_cast<double>(state.env_steps_per_task) / budget)
            : config.learning_rate;
    adam.set_lr(record.learning_rate);

    // 1. Rollout.
    std::vector<std::uint64_t> seeds(envs.size());
    for (std::size_t i = 0; i < envs.size(); ++i)
      seeds[i] = rollout_seed(seed, env_tasks[i],
                              state.iteration * config.rollout_episodes +
                                  static_cast<std::int64_t>(i % static_cast<std::size_t>(config.rollout_episodes)));
    RolloutTimes times;
    const Rollout rollout =
        collect_rollout(envs, env_tasks, seeds, policy, head.log_std(), data.standardizer(), K, noise, times);
    summary.physics_seconds += times.physics_seconds;
    summary.rollout_policy_seconds += times.policy_seconds;
    const std::int64_t N = rollout.rows();
    std::int64_t fewest = N;
    for (const auto& rows : rollout.task_rows)
      fewest = std::min<std::int64_t>(fewest, static_cast<std::int64_t>(rows.size()));
    record.task_returns.assign(static_cast<std::size_t>(K), 0.0);
    double successes = 0.0;
    for (std::size_t e = 0; e < rollout.episode_return.size(); ++e) {
      record.task_returns[static_cast<std::size_t>(rollout.episode_task[e])] +=
          rollout.episode_return[e] / config.rollout_episodes;
      successes += rollout.episode_success[e] ? 1.0 : 0.0;
    }
    record.success = successes / static_cast<double>(rollout.episode_return.size());

    const ag::Tensor observations = ag::from_eigen(rollout.observations);
    const ag::Tensor previous = ag::from_eigen(rollout.previous_observations);
    const ag::Tensor actions = ag::from_eigen(rollout.actions);
    const ag::Tensor pairs = ag::concat({observations, ag::from_eigen(rollout.executed_actions)}, 1);

    // 2. Discriminator, then the rewards it gives.
    auto phase_start = std::chrono::steady_clock::now();
    const int updates = iteration <= config.discriminator_warmup_iterations ? config.discriminator_warmup_updates
                                                                            : config.discriminator_updates;
    train_discriminator(discriminator, discriminator_adam, data, rollout, pairs, config, updates, rng, noise, iteration,
                        record);
    Eigen::VectorXd rewards;
    {
      ag::NoGradGuard no_grad;
      rewards = ag::to_eigen_double(gail_reward(discriminator.logits_of_pairs(pairs, rollout.tasks), config.reward))
                    .reshaped();
    }
    check_finite(rewards.sum(), "the discriminator's reward", iteration);
    record.reward = rewards.mean();
    summary.discriminator_seconds += seconds_since(phase_start);

    // 3. Advantages: each task's rewards over the running std of its discounted return, then GAE per episode.
    phase_start = std::chrono::steady_clock::now();
    Eigen::VectorXd values, final_values;
    {
      ag::NoGradGuard no_grad;
      values = ag::to_eigen_double(head.value(observations, rollout.tasks)).reshaped();
      final_values =
          ag::to_eigen_double(head.value(ag::from_eigen(rollout.final_observations), rollout.episode_task)).reshaped();
    }
    Eigen::VectorXd advantages(N), returns(N);
    for (std::size_t e = 0; e < rollout.episode_start.size(); ++e) {
      const std::int64_t start = rollout.episode_start[e], length = rollout.episode_length[e];
      Eigen::VectorXd episode_rewards = rewards.segment(start, length);
      if (config.normalize_reward) {
        rl::RewardScaler& scaler = reward_scalers[static_cast<std::size_t>(rollout.episode_task[e])];
        for (std::int64_t t = 0; t < length; ++t)
          episode_rewards(t) = scaler.scale(episode_rewards(t), t + 1 == length);
      }
      Eigen::VectorXd next_values(length);
      next_values.head(length - 1) = values.segment(start + 1, length - 1);
      next_values(length - 1) = final_values(static_cast<Eigen::Index>(e));
      std::vector<bool> terminated(static_cast<std::size_t>(length), false),
          ends(static_cast<std::size_t>(length), false);
      terminated.back() = rollout.episode_terminated[e];
      ends.back() = true;
      const rl::GaeResult gae = rl::compute_gae(episode_rewards, values.segment(start, length), next_values, terminated,
                                                ends, config.gamma, config.gae_lambda);
      advantages.segment(start, length) = gae.advantages;
      returns.segment(start, length) = gae.returns;
    }

    // 4. PPO epochs on balanced minibatches (the same rows of every task), plus the method's regularisers and BC.
    const std::int64_t per_task = std::min(config.minibatch_per_task, fewest);
    const std::int64_t minibatches = std::max<std::int64_t>(1, fewest / per_task);
    std::vector<std::vector<std::int64_t>> shuffled = rollout.task_rows;
    double terms = 0.0;
    std::vector<double> regularizer_sums;
    for (int epoch = 0; epoch < config.epochs; ++epoch) {
      for (auto& rows : shuffled) shuffle(rows, rng);
      for (std::int64_t m = 0; m < minibatches; ++m) {
        std::vector<std::int64_t> rows;
        rows.reserve(static_cast<std::size_t>(K * per_task));
        for (const auto& own : shuffled)
          rows.insert(rows.end(), own.begin() + m * per_task, own.begin() + (m + 1) * per_task);
        core::Batch batch;
        batch.observations = rows_of(observations, rows);
        batch.previous_observations = rows_of(previous, rows);
        batch.actions = rows_of(actions, rows);
        batch.tasks.resize(rows.size());
        for (std::size_t j = 0; j < rows.size(); ++j) batch.tasks[j] = rollout.tasks[static_cast<std::size_t>(rows[j])];
        batch.per_task = per_task;
        batch.noise_seed = rng();

        Eigen::VectorXd adv(static_cast<Eigen::Index>(rows.size()));
        for (std::size_t j = 0; j < rows.size(); ++j) adv(static_cast<Eigen::Index>(j)) = advantages(rows[j]);
        const double adv_mean = adv.mean();
        const double adv_std = std::sqrt((adv.array() - adv_mean).square().mean());
        adv = (adv.array() - adv_mean) / (adv_std + 1e-8);

        const core::PolicyForward forward = policy.forward_terms(batch);
        const ag::Tensor log_prob = rl::gaussian_log_prob(forward.mean_actions, head.log_std(), batch.actions);
        const ag::Tensor old_log_prob = vector_tensor(rollout.log_probs, rows);
        const ag::Tensor policy_loss = rl::ppo_clip_loss(
            log_prob, old_log_prob,
            ag::from_vector(std::vector<double>(adv.data(), adv.data() + adv.size()), {adv.size()}), config.clip);
        const ag::Tensor value_loss =
            ag::mean(ag::square(head.value(batch.observations, batch.tasks) - vector_tensor(returns, rows)));
        const ag::Tensor entropy = rl::gaussian_entropy(head.log_std());
        ag::Tensor total = policy_loss + value_loss * config.value_coef - entropy * config.entropy_coef;
        if (forward.regularizer.total.defined()) total = total + forward.regularizer.total;
        ag::Tensor bc;
        if (config.bc_weight > 0.0) {
          core::Batch demos = data.sample(config.bc_states_per_task, rng, ag::Dtype::Float32);
          demos.noise_seed = rng();
          bc = policy.loss(demos).total;
          total = total + bc * config.bc_weight;
        }
        const double total_value = total.item();
        check_finite(total_value, "the PPO loss", iteration);
        policy.zero_grad();
        head.zero_grad();
        total.backward();
        check_finite(nn::clip_grad_norm_(params, config.max_grad_norm), "the gradient norm", iteration);
        adam.step();
        policy.after_step();

        const Eigen::VectorXd log_ratio = ag::to_eigen_double((log_prob - old_log_prob).detach()).reshaped();
        record.approx_kl += ((log_ratio.array().exp() - 1.0) - log_ratio.array()).mean();
        record.clip_fraction += ((log_ratio.array().exp() - 1.0).abs() > config.clip).cast<double>().mean();
        record.policy_loss += policy_loss.item();
        record.value_loss += value_loss.item();
        record.entropy += entropy.item();
        if (bc.defined()) record.bc += bc.item();
        if (regularizer_sums.empty()) regularizer_sums.assign(forward.regularizer.terms.size(), 0.0);
        for (std::size_t j = 0; j < forward.regularizer.terms.size(); ++j)
          regularizer_sums[j] += forward.regularizer.terms[j].second.item();
        if (record.regularizer.empty())
          for (const auto& [name, value] : forward.regularizer.terms) record.regularizer.emplace_back(name, 0.0);
        terms += 1.0;
      }
    }
    policy.zero_grad();
    head.zero_grad();
    for (double* value : {&record.approx_kl, &record.clip_fraction, &record.policy_loss, &record.value_loss,
                          &record.entropy, &record.bc})
      *value /= terms;
    for (std::size_t j = 0; j < record.regularizer.size(); ++j)
      record.regularizer[j].second = regularizer_sums[j] / terms;
    summary.ppo_seconds += seconds_since(phase_start);

    // 5. Validation, the curve, checkpoints.
    phase_start = std::chrono::steady_clock::now();
    record.validation_bc = core::mean_action_error(policy, validation);
    check_finite(record.validation_bc, "the validation loss", iteration);
    state.iteration = iteration;
    state.env_steps_per_task += N / K;
    record.env_steps_per_task = state.env_steps_per_task;
    record.env_steps_per_second = static_cast<double>(N) / seconds_since(iteration_start);
    if (cpu_column) record.cpu_seconds = core::process_cpu_seconds() - iteration_cpu_start;
    summary.env_steps_this_process += N;
    const bool best = config.checkpoint == "last" || record.validation_bc < state.best_validation;
    if (best) {
      state.best_iteration = iteration;
      state.best_validation = record.validation_bc;
      core::PolicyRecord policy_record;
      policy_record.step = iteration;
      policy_record.validation_bc = record.validation_bc;
      policy_record.standardizer = data.standardizer();
      nn::save(policy, best_path, core::to_json(policy_record).dump());
    }
    {
      std::ofstream curve(curve_path, std::ios::app);
      if (!header_written) curve << curve_header(record, data.task_names()) << "\n";
      header_written = true;
      curve << curve_row(record) << "\n";
      if (!curve.flush()) throw std::runtime_error("cannot append to " + curve_path);
    }
    ++iterations_here;
    const bool last = state.env_steps_per_task >= config.env_steps_per_task ||
                      (max_iterations >= 0 && iterations_here >= max_iterations);
    if (iteration % config.checkpoint_every == 0 || last) {
      GailModules modules{policy, head, discriminator, adam, discriminator_adam, reward_scalers};
      save_gail_state(last_path, state, modules, rng, noise);
    }
    summary.other_seconds += seconds_since(phase_start);
    if (log) {
      double mean_return = 0.0;
      for (const double r : record.task_returns) mean_return += r / static_cast<double>(K);
      char line[512];
      std::snprintf(line, sizeof line,
                    "gail iteration %lld: %lld env steps per task (%.0f%%), return %.1f, success %.2f, D loss %.3f "
                    "(demos %.2f, policy %.2f), reward %.3f, value loss %.3f, kl %.4f, clip %.3f, validation %.4f, "
                    "%.0f steps/s\n",
                    static_cast<long long>(iteration), static_cast<long long>(state.env_steps_per_task),
                    100.0 * static_cast<double>(state.env_steps_per_task) / budget, mean_return, record.success,
                    record.discriminator_loss, record.expert_accuracy, record.policy_accuracy, record.reward,
                    record.value_loss, record.approx_kl, record.clip_fraction, record.validation_bc,
                    record.env_steps_per_second);
      *log << line << std::flush;
    }
  }
  if (!fs::exists(best_path))
    throw std::runtime_error("train_gail: no iteration ran and " + best_path + " does not exist");
  nn::load(policy, best_path);
  summary.iterations = state.iteration;
  summary.env_steps_per_task = state.env_steps_per_task;
  summary.best_iteration = state.best_iteration;
  summary.best_validation_loss = state.best_validation;
  summary.seconds = seconds_since(wall_start);
  return summary;
}

}  // namespace maps::adversarial
