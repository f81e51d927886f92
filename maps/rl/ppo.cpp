#include "maps/rl/ppo.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <numbers>
#include <ostream>
#include <sstream>
#include <stdexcept>
#include <utility>

#include "io/json_input.h"
#include "maps/rl/gae.h"

namespace maps::rl {
namespace {

using Json = nlohmann::json;
constexpr const char* kCheckpointFormat = "maps-ppo-checkpoint-1";
constexpr const char* kCheckpointFile = "checkpoint.ckpt";

ag::Tensor row_tensor(const Eigen::VectorXd& x) {
  ag::Tensor out = ag::empty({1, x.size()});
  out.matrix<float>() = x.transpose().cast<float>();
  return out;
}

ag::Tensor vector_tensor(const Eigen::VectorXd& x, ag::Dtype dtype) {
  ag::Tensor out = ag::empty({x.size()}, dtype);
  if (dtype == ag::Dtype::Float32)
    out.array<float>() = x.array().cast<float>();
  else
    out.array<double>() = x.array();
  return out;
}

Eigen::VectorXd to_vector_d(const ag::Tensor& t) {
  const std::vector<double> v = t.to_vector();
  return Eigen::Map<const Eigen::VectorXd>(v.data(), static_cast<Eigen::Index>(v.size()));
}

// The model's mean action for one raw observation, as double.
Eigen::VectorXd mean_action_of(ActorCritic& model, const RunningMeanStd& obs_stats, const Eigen::VectorXd& obs) {
  ag::NoGradGuard no_grad;
  return to_vector_d(model.mean_action(row_tensor(obs_stats.normalize(obs))));
}

Eigen::VectorXd clip_to_bounds(const Eigen::VectorXd& a, const envs::EnvSpec& spec) {
  if (spec.action_low.size() != a.size() || spec.action_high.size() != a.size()) return a;
  return a.cwiseMax(spec.action_low).cwiseMin(spec.action_high);
}

std::string format_duration(double seconds) {
  if (!std::isfinite(seconds) || seconds < 0) return "?";
  const auto s = static_cast<long long>(seconds + 0.5);
  char buf[64];
  if (s >= 3600)
    std::snprintf(buf, sizeof buf, "%lldh%02lldm", s / 3600, (s / 60) % 60);
  else
    std::snprintf(buf, sizeof buf, "%lldm%02llds", s / 60, s % 60);
  return buf;
}

Json config_json(const PPOConfig& c) {
  return Json{{"total_steps", c.total_steps},
              {"steps_per_rollout", c.steps_per_rollout},
              {"epochs", c.epochs},
              {"minibatch_size", c.minibatch_size},
              {"gamma", c.gamma},
              {"gae_lambda", c.gae_lambda},
              {"clip", c.clip},
              {"learning_rate", c.learning_rate},
              {"adam_eps", c.adam_eps},
              {"anneal_learning_rate", c.anneal_learning_rate},
              {"value_coef", c.value_coef},
              {"entropy_coef", c.entropy_coef},
              {"max_grad_norm", c.max_grad_norm},
              {"normalize_observations", c.normalize_observations},
              {"scale_rewards", c.scale_rewards},
              {"hidden", c.hidden},
              {"seed", c.seed},
              {"pitch_index", c.pitch_index},
              {"end_episode_at_pitch", c.end_episode_at_pitch}};
}

}  // namespace

std::uint64_t training_episode_seed(std::uint64_t seed, std::int64_t episode) {
  // splitmix64 of the run seed, then consecutive episodes.
  std::uint64_t z = seed + 0x9E3779B97F4A7C15ULL;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  z ^= z >> 31;
  return (z >> 1) + static_cast<std::uint64_t>(episode);
}

struct PPOTrainer::Rollout {
  ag::RowMatrixF obs;       // normalised observations the actions were taken in
  ag::RowMatrixF actions;   // unclipped samples
  Eigen::VectorXd rewards;  // scaled
  std::vector<bool> terminated;
  std::vector<bool> episode_end;
  std::vector<std::pair<int, Eigen::VectorXd>> bootstrap;  // step -> normalised observation to bootstrap from
  int episodes_finished = 0;
  int flipped_steps = 0;
};

PPOTrainer::PPOTrainer(envs::Env& env, const PPOConfig& config, std::string out_dir, std::ostream* log)
    : env_(env),
      config_(config),
      out_dir_(std::move(out_dir)),
      log_(log),
      obs_rms_(env.spec().observation_size),
      reward_scaler_(config.gamma),
      rng_(config.seed ^ 0x5DEECE66DULL),
      end_cos_(std::cos(config.end_episode_at_pitch)) {
  const auto& spec = env.spec();
  if (config.total_steps <= 0 || config.steps_per_rollout <= 0 || config.epochs <= 0 || config.minibatch_size <= 0)
    throw std::invalid_argument("PPOTrainer: total_steps, steps_per_rollout, epochs and minibatch_size must be > 0");
  if (spec.observation_size <= 0 || spec.action_size <= 0)
    throw std::invalid_argument("PPOTrainer: env '" + spec.task + "' has no observation or action size");
  if (config.pitch_index >= spec.observation_size)
    throw std::invalid_argument("PPOTrainer: pitch_index " + std::to_string(config.pitch_index) +
                                " is past the observation size " + std::to_string(spec.observation_size));
  if (!(config.end_episode_at_pitch >= 0.0 && config.end_episode_at_pitch < std::numbers::pi) ||
      (config.end_episode_at_pitch > 0.0 && config.pitch_index < 0))
    throw std::invalid_argument("PPOTrainer: end_episode_at_pitch must be in [0, pi) radians (got " +
                                std::to_string(config.end_episode_at_pitch) +
                                ") and needs pitch_index, the observation entry holding the torso's pitch "
                                "(HalfCheetah: 1)");
  ag::Generator init_gen(config.seed);
  model_ = std::make_shared<ActorCritic>(
      ActorCriticConfig{
          .observation_size = spec.observation_size, .action_size = spec.action_size, .hidden = config.hidden},
      init_gen);
  params_ = model_->parameters();
  for (const auto& p : params_) {
    if (p.dtype() != ag::Dtype::Float32) throw std::logic_error("PPOTrainer: parameters must be float32");
    adam_m_.push_back(ag::zeros(p.shape()));
    adam_v_.push_back(ag::zeros(p.shape()));
  }
}

std::int64_t PPOTrainer::total_iterations() const {
  return (config_.total_steps + config_.steps_per_rollout - 1) / config_.steps_per_rollout;
}

double PPOTrainer::recent_mean_return() const {
  if (recent_returns_.empty()) return std::numeric_limits<double>::quiet_NaN();
  double sum = 0.0;
  for (double r : recent_returns_) sum += r;
  return sum / static_cast<double>(recent_returns_.size());
}

void PPOTrainer::start_episode() {
  episode_seed_ = training_episode_seed(config_.seed, episode_index_++);
  current_obs_ = env_.reset(episode_seed_);
  episode_actions_.clear();
  episode_return_ = 0.0;
  episode_active_ = true;
  if (config_.normalize_observations) obs_rms_.update(current_obs_);
}

void PPOTrainer::collect(Rollout& r) {
  const auto& spec = env_.spec();
  const int n = config_.steps_per_rollout;
  r.obs.resize(n, spec.observation_size);
  r.actions.resize(n, spec.action_size);
  r.rewards.resize(n);
  r.terminated.assign(n, false);
  r.episode_end.assign(n, false);
  if (!episode_active_) start_episode();
  const Eigen::VectorXd std_dev = to_vector_d(model_->log_std()).array().exp().matrix();
  Eigen::VectorXd action(spec.action_size);
  for (int t = 0; t < n; ++t) {
    if (config_.pitch_index >= 0 && std::cos(current_obs_(config_.pitch_index)) < 0.0) ++r.flipped_steps;
    const Eigen::VectorXd obs = obs_rms_.normalize(current_obs_);
    r.obs.row(t) = obs.transpose().cast<float>();
    Eigen::VectorXd mean;
    {
      ag::NoGradGuard no_grad;
      mean = to_vector_d(model_->mean_action(row_tensor(obs)));
    }
    for (int d = 0; d < spec.action_size; ++d) action(d) = mean(d) + std_dev(d) * rng_.normal();
    r.actions.row(t) = action.transpose().cast<float>();
    const Eigen::VectorXd clipped = clip_to_bounds(action, spec);
    const envs::StepResult result = env_.step(clipped);
    episode_actions_.push_back(clipped);
    ++steps_done_;
    episode_return_ += result.reward;
    // cos compares angles that may have wound past pi (the pitch is an unwrapped hinge angle).
    // A step past the angle ends the episode as terminated even when it is also the time limit's last step: the
    // tilted-over state must not be bootstrapped from.
    const bool ended_flipped =
        config_.end_episode_at_pitch > 0.0 && std::cos(result.observation(config_.pitch_index)) < end_cos_;
    const bool terminated = result.terminated || ended_flipped;
    const bool done = result.done() || ended_flipped;
    r.rewards(t) = config_.scale_rewards ? reward_scaler_.scale(result.reward, done) : result.reward;
    r.terminated[t] = terminated;
    r.episode_end[t] = done;
    if (done) {
      if (!terminated) r.bootstrap.emplace_back(t, obs_rms_.normalize(result.observation));
      recent_returns_.push_back(episode_return_);
      while (static_cast<int>(recent_returns_.size()) > std::max(1, config_.recent_episodes))
        recent_returns_.pop_front();
      ++r.episodes_finished;
      episode_active_ = false;
      start_episode();
    } else {
      current_obs_ = result.observation;
      if (config_.normalize_observations) obs_rms_.update(current_obs_);
      if (t == n - 1) r.bootstrap.emplace_back(t, obs_rms_.normalize(current_obs_));
    }
  }
}

void PPOTrainer::adam_step(double learning_rate) {
  ag::NoGradGuard no_grad;
  constexpr double beta1 = 0.9, beta2 = 0.999;
  ++adam_t_;
  const double t = static_cast<double>(adam_t_);
  const double bias_correction1 = 1.0 - std::pow(beta1, t);
  const double bias_correction2_sqrt = std::sqrt(1.0 - std::pow(beta2, t));
  const auto step_size = static_cast<float>(learning_rate / bias_correction1);
  const auto b1 = static_cast<float>(beta1), b2 = static_cast<float>(beta2);
  const auto c1 = static_cast<float>(1.0 - beta1), c2 = static_cast<float>(1.0 - beta2);
  const auto bc2 = static_cast<float>(bias_correction2_sqrt), eps = static_cast<float>(config_.adam_eps);
  for (std::size_t i = 0; i < params_.size(); ++i) {
    const ag::Tensor grad = params_[i].grad();
    if (!grad.defined()) continue;  // (every parameter gets one: log_std, policy and value all enter the loss)
    auto p = params_[i].array<float>();
    auto g = grad.array<float>();
    auto m = adam_m_[i].array<float>();
    auto v = adam_v_[i].array<float>();
    m = b1 * m + c1 * g;
    v = b2 * v + c2 * g.square();
    p -= step_size * m / (v.sqrt() / bc2 + eps);
  }
}

PPOIterationStats PPOTrainer::update(const Rollout& r, double learning_rate) {
  const int n = static_cast<int>(r.obs.rows());
  const auto obs_size = r.obs.cols();
  const auto act_size = r.actions.cols();
  PPOIterationStats stats;
  stats.learning_rate = learning_rate;
  stats.episodes_finished = r.episodes_finished;
  stats.flipped_fraction = static_cast<double>(r.flipped_steps) / std::max(1, n);

  // Values of every observation and of the bootstrap observations, and the old log-probabilities, in one pass.
  Eigen::VectorXd values, next_values, old_log_prob;
  {
    ag::NoGradGuard no_grad;
    ag::RowMatrixF all(n + static_cast<Eigen::Index>(r.bootstrap.size()), obs_size);
    all.topRows(n) = r.obs;
    for (std::size_t k = 0; k < r.bootstrap.size(); ++k)
      all.row(n + static_cast<Eigen::Index>(k)) = r.bootstrap[k].second.transpose().cast<float>();
    const Eigen::VectorXd all_values = to_vector_d(model_->value(ag::from_eigen(all)));
    values = all_values.head(n);
    next_values = Eigen::VectorXd::Zero(n);
    if (n > 1) next_values.head(n - 1) = values.tail(n - 1);
    for (std::size_t k = 0; k < r.bootstrap.size(); ++k)
      next_values(r.bootstrap[k].first) = all_values(n + static_cast<Eigen::Index>(k));
    const ag::Tensor obs = ag::from_eigen(r.obs);
    old_log_prob =
        to_vector_d(gaussian_log_prob(model_->mean_action(obs), model_->log_std(), ag::from_eigen(r.actions)));
  }
  const GaeResult gae =
      compute_gae(r.rewards, values, next_values, r.terminated, r.episode_end, config_.gamma, config_.gae_lambda);

  std::vector<int> order(n);
  for (int i = 0; i < n; ++i) order[i] = i;
  const int mb = std::min(config_.minibatch_size, n);
  ag::RowMatrixF mb_obs, mb_act;
  Eigen::VectorXd mb_old, mb_adv, mb_ret;
  double sum_pg = 0, sum_v = 0, sum_kl = 0, sum_clip = 0, sum_entropy = 0;
  int batches = 0;
  for (int epoch = 0; epoch < config_.epochs; ++epoch) {
    for (int i = n - 1; i > 0; --i) std::swap(order[i], order[rng_.next_u64() % static_cast<std::uint64_t>(i + 1)]);
    for (int start = 0; start < n; start += mb) {
      const int size = std::min(mb, n - start);
      mb_obs.resize(size, obs_size);
      mb_act.resize(size, act_size);
      mb_old.resize(size);
      mb_adv.resize(size);
      mb_ret.resize(size);
      for (int j = 0; j < size; ++j) {
        const int idx = order[start + j];
        mb_obs.row(j) = r.obs.row(idx);
        mb_act.row(j) = r.actions.row(idx);
        mb_old(j) = old_log_prob(idx);
        mb_adv(j) = gae.advantages(idx);
        mb_ret(j) = gae.returns(idx);
      }
      const double adv_mean = mb_adv.mean();
      const double adv_std =
          size > 1 ? std::sqrt((mb_adv.array() - adv_mean).square().sum() / static_cast<double>(size - 1)) : 0.0;
      mb_adv = ((mb_adv.array() - adv_mean) / (adv_std + 1e-8)).matrix();

      const ag::Tensor obs = ag::from_eigen(mb_obs);
      const ag::Tensor log_prob =
          gaussian_log_prob(model_->mean_action(obs), model_->log_std(), ag::from_eigen(mb_act));
      const ag::Tensor old_t = vector_tensor(mb_old, ag::Dtype::Float32);
      const ag::Tensor pg_loss =
          ppo_clip_loss(log_prob, old_t, vector_tensor(mb_adv, ag::Dtype::Float32), config_.clip);
      const ag::Tensor value_loss = ag::mse_loss(model_->value(obs), vector_tensor(mb_ret, ag::Dtype::Float32));
      const ag::Tensor entropy = gaussian_entropy(model_->log_std());
      ag::Tensor loss = pg_loss + value_loss * config_.value_coef;
      if (config_.entropy_coef != 0.0) loss = loss - entropy * config_.entropy_coef;
      const double loss_value = loss.item();
      if (!std::isfinite(loss_value))
        throw std::runtime_error("PPO: the loss is not finite (" + std::to_string(loss_value) + ") at iteration " +
                                 std::to_string(iteration_ + 1) + ", epoch " + std::to_string(epoch + 1) +
                                 " on task '" + env_.spec().task +
                                 "'; stopping, the last checkpoint (if any) is the last good state");
      model_->zero_grad();
      loss.backward();
      const double norm = nn::clip_grad_norm_(params_, config_.max_grad_norm);
      if (!std::isfinite(norm))
        throw std::runtime_error("PPO: the gradient norm is not finite at iteration " + std::to_string(iteration_ + 1) +
                                 " on task '" + env_.spec().task + "'; stopping, the last checkpoint is kept");
      adam_step(learning_rate);

      {
        const Eigen::ArrayXd log_ratio = to_vector_d(log_prob).array() - mb_old.array();
        const Eigen::ArrayXd ratio = log_ratio.exp();
        sum_kl += ((ratio - 1.0) - log_ratio).mean();
        sum_clip += ((ratio - 1.0).abs() > config_.clip).cast<double>().mean();
        sum_pg += pg_loss.item();
        sum_v += value_loss.item();
        sum_entropy += entropy.item();
        ++batches;
      }
    }
  }
  if (batches > 0) {
    stats.policy_loss = sum_pg / batches;
    stats.value_loss = sum_v / batches;
    stats.entropy = sum_entropy / batches;
    stats.approx_kl = sum_kl / batches;
    stats.clip_fraction = sum_clip / batches;
  }
  model_->zero_grad();
  return stats;
}

int PPOTrainer::train(int max_iterations) {
  if (!resume_checked_) resume();
  const std::int64_t total = total_iterations();
  int run = 0;
  double seconds_this_run = 0.0;
  bool saved_last = true;
  while (iteration_ < total && (max_iterations < 0 || run < max_iterations)) {
    const auto start = std::chrono::steady_clock::now();
    const double lr = config_.anneal_learning_rate
                          ? config_.learning_rate * (1.0 - static_cast<double>(iteration_) / static_cast<double>(total))
                          : config_.learning_rate;
    Rollout rollout;
    collect(rollout);
    PPOIterationStats stats = update(rollout, lr);
    ++iteration_;
    ++run;
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    seconds_this_run += seconds;
    stats.iteration = iteration_;
    stats.steps = steps_done_;
    stats.recent_return = recent_mean_return();
    stats.fps = config_.steps_per_rollout / std::max(seconds, 1e-9);
    history_.push_back(stats);
    saved_last = false;
    if (!out_dir_.empty() && config_.checkpoint_every > 0 && iteration_ % config_.checkpoint_every == 0) {
      save_checkpoint();
      saved_last = true;
    }
    if (log_) {
      const double eta = seconds_this_run / run * static_cast<double>(total - iteration_);
      char line[320];
      std::snprintf(line, sizeof line,
                    "iter %lld/%lld  steps %lld  return %.1f (last %zu ep)  pg %.4f  v %.4f  kl %.4f  clip %.3f  "
                    "std %.3f  lr %.2e  flipped %.2f  fps %.0f  eta %s",
                    static_cast<long long>(iteration_), static_cast<long long>(total),
                    static_cast<long long>(steps_done_), stats.recent_return, recent_returns_.size(), stats.policy_loss,
                    stats.value_loss, stats.approx_kl, stats.clip_fraction,
                    to_vector_d(model_->log_std()).array().exp().mean(), lr, stats.flipped_fraction, stats.fps,
                    format_duration(eta).c_str());
      *log_ << line << std::endl;
    }
    if (callback_ && !callback_(stats)) break;
  }
  if (!out_dir_.empty() && !saved_last) save_checkpoint();
  return run;
}

std::string PPOTrainer::checkpoint_path() const {
  return out_dir_.empty() ? std::string() : (std::filesystem::path(out_dir_) / kCheckpointFile).string();
}

std::string PPOTrainer::state_text() const {
  std::ostringstream rng_text;
  rng_text << const_cast<ag::Generator&>(rng_).engine();
  Json j{{"format", kCheckpointFormat},
         {"task", env_.spec().task},
         {"config", config_json(config_)},
         {"steps_done", steps_done_},
         {"iteration", iteration_},
         {"adam_step", adam_t_},
         {"obs_count", obs_rms_.count()},
         {"return_count", reward_scaler_.stats().count()},
         {"discounted_return", reward_scaler_.discounted_return()},
         {"episode_index", episode_index_},
         {"episode_seed", episode_seed_},
         {"episode_return", episode_return_},
         {"episode_active", episode_active_},
         {"recent_returns", std::vector<double>(recent_returns_.begin(), recent_returns_.end())},
         {"rng", rng_text.str()}};
  return j.dump(1);
}

void PPOTrainer::save_checkpoint() const {
  if (out_dir_.empty()) return;
  std::filesystem::create_directories(out_dir_);
  nn::NamedTensors tensors = model_->state_dict();
  const nn::NamedTensors named = model_->named_parameters();
  for (std::size_t i = 0; i < named.size(); ++i) {
    tensors.push_back({"ppo.adam_m." + named[i].name, adam_m_[i]});
    tensors.push_back({"ppo.adam_v." + named[i].name, adam_v_[i]});
  }
  tensors.push_back({"ppo.obs_mean", vector_tensor(obs_rms_.mean(), ag::Dtype::Float64)});
  tensors.push_back({"ppo.obs_var", vector_tensor(obs_rms_.var(), ag::Dtype::Float64)});
  tensors.push_back({"ppo.return_mean", vector_tensor(reward_scaler_.stats().mean(), ag::Dtype::Float64)});
  tensors.push_back({"ppo.return_var", vector_tensor(reward_scaler_.stats().var(), ag::Dtype::Float64)});
  if (!episode_actions_.empty()) {
    const auto act = static_cast<Eigen::Index>(env_.spec().action_size);
    ag::RowMatrixD actions(static_cast<Eigen::Index>(episode_actions_.size()), act);
    for (std::size_t k = 0; k < episode_actions_.size(); ++k)
      actions.row(static_cast<Eigen::Index>(k)) = episode_actions_[k].transpose();
    tensors.push_back({"ppo.episode_actions", ag::from_eigen(actions)});
  }
  nn::save_tensors(checkpoint_path(), tensors, state_text());
}

std::string PPOTrainer::load_tensors_from(const std::string& path, bool with_optimizer) {
  nn::Checkpoint ckpt = nn::load_tensors(path);
  const Json j = io::parse_json(ckpt.config, "PPO checkpoint " + path + "'s state text");
  if (io::string_or(j, "format", "") != kCheckpointFormat)
    throw std::runtime_error("PPO checkpoint " + path + ": not a " + kCheckpointFormat + " file");
  nn::NamedTensors model_state;
  std::map<std::string, ag::Tensor> extra;
  for (auto& nt : ckpt.tensors) {
    if (nt.name.rfind("ppo.", 0) == 0)
      extra[nt.name] = nt.tensor;
    else
      model_state.push_back(nt);
  }
  auto need = [&](const std::string& name) {
    auto it = extra.find(name);
    if (it == extra.end()) throw std::runtime_error("PPO checkpoint " + path + ": missing tensor '" + name + "'");
    return it->second;
  };
  try {
    model_->load_state_dict(model_state);
  } catch (const std::exception& e) {
    throw std::runtime_error("PPO checkpoint " + path + ": " + e.what());
  }
  if (with_optimizer) {
    const nn::NamedTensors named = model_->named_parameters();
    for (std::size_t i = 0; i < named.size(); ++i) {
      adam_m_[i].copy_(need("ppo.adam_m." + named[i].name));
      adam_v_[i].copy_(need("ppo.adam_v." + named[i].name));
    }
  }
  // The counts and the running return: a record edited or damaged by hand names the checkpoint, not the JSON library.
  double obs_count = 0.0, return_count = 0.0, discounted_return = 0.0;
  try {
    obs_count = j.at("obs_count").get<double>();
    return_count = j.at("return_count").get<double>();
    if (with_optimizer) discounted_return = j.at("discounted_return").get<double>();
  } catch (const nlohmann::json::exception& e) {
    throw std::runtime_error("PPO checkpoint " + path + ": obs_count, return_count and discounted_return must be " +
                             "numbers (" + e.what() + ")");
  }
  if (!(obs_count >= 0.0) || !(return_count >= 0.0) || !std::isfinite(obs_count) || !std::isfinite(return_count) ||
      !std::isfinite(discounted_return))
    throw std::runtime_error("PPO checkpoint " + path + ": obs_count and return_count must be finite and >= 0, " +
                             "discounted_return finite");
  obs_rms_.set_state(to_vector_d(need("ppo.obs_mean")), to_vector_d(need("ppo.obs_var")), obs_count);
  if (obs_rms_.size() != env_.spec().observation_size)
    throw std::runtime_error("PPO checkpoint " + path + ": observation statistics of the wrong size");
  RunningMeanStd ret_stats(1);
  ret_stats.set_state(to_vector_d(need("ppo.return_mean")), to_vector_d(need("ppo.return_var")), return_count);
  reward_scaler_.set_state(discounted_return, ret_stats);
  episode_actions_.clear();
  if (with_optimizer && extra.count("ppo.episode_actions")) {
    const ag::RowMatrixD actions = ag::to_eigen_double(extra["ppo.episode_actions"]);
    for (Eigen::Index k = 0; k < actions.rows(); ++k) episode_actions_.push_back(actions.row(k).transpose());
  }
  return ckpt.config;
}

void PPOTrainer::warm_start_from(const std::string& path) {
  load_tensors_from(path, /*with_optimizer=*/false);
  if (log_) *log_ << "warm start from " << path << " (weights and normalisers)" << std::endl;
}

// A resumed run must continue the same recipe; only the step budget and the logging/checkpoint cadence may change.
// A key the checkpoint lacks (written before the key existed) counts as that key's default.
void PPOTrainer::check_same_recipe(const std::string& path, const Json& saved) const {
  const Json current = config_json(config_), defaults = config_json(PPOConfig{});
  for (const auto& [key, value] : current.items()) {
    if (key == "total_steps" || key == "checkpoint_every" || key == "recent_episodes") continue;
    const Json& before = saved.contains(key) ? saved.at(key) : defaults.at(key);
    if (before != value)
      throw std::runtime_error("PPO checkpoint " + path + " was trained with " + key + " = " + before.dump() +
                               ", this run asks for " + value.dump() +
                               "; resume with the same settings, or start a new folder (--init warm-starts from it)");
  }
}

bool PPOTrainer::resume() {
  resume_checked_ = true;
  if (out_dir_.empty() || !std::filesystem::exists(checkpoint_path())) return false;
  const std::string path = checkpoint_path();
  const Json j = io::parse_json(load_tensors_from(path, /*with_optimizer=*/true), "PPO checkpoint " + path);
  if (io::string_or(j, "task", "") != env_.spec().task)
    throw std::runtime_error("PPO checkpoint " + path + " was trained on task '" + io::string_or(j, "task", "") +
                             "', not '" + env_.spec().task + "'");
  check_same_recipe(path, j.value("config", Json::object()));
  steps_done_ = j.at("steps_done");
  iteration_ = j.at("iteration");
  adam_t_ = j.at("adam_step");
  episode_index_ = j.at("episode_index");
  episode_seed_ = j.at("episode_seed");
  episode_return_ = j.at("episode_return");
  episode_active_ = j.at("episode_active");
  const std::vector<double> recent = j.at("recent_returns");
  recent_returns_.assign(recent.begin(), recent.end());
  std::istringstream rng_text(j.at("rng").get<std::string>());
  rng_text >> rng_.engine();
  if (rng_text.fail()) throw std::runtime_error("PPO checkpoint " + path + ": unreadable RNG state");

  // Rebuild the episode in progress by replaying its actions from its seed.
  if (episode_active_) {
    current_obs_ = env_.reset(episode_seed_);
    for (std::size_t k = 0; k < episode_actions_.size(); ++k) {
      const envs::StepResult res = env_.step(episode_actions_[k]);
      if (res.done())
        throw std::runtime_error("PPO checkpoint " + path + ": replaying the episode in progress ended it at step " +
                                 std::to_string(k) + "; the env is not deterministic");
      current_obs_ = res.observation;
    }
  } else {
    episode_actions_.clear();
  }
  if (log_)
    *log_ << "resumed from " << path << " at iteration " << iteration_ << ", " << steps_done_ << " steps" << std::endl;
  return true;
}

envs::ExpertPolicy export_expert(const ActorCritic& model, const RunningMeanStd& obs_stats, const std::string& task,
                                 const std::string& metadata_json) {
  envs::ExpertPolicy e;
  e.task = task;
  e.obs_mean = obs_stats.mean();
  e.obs_var = obs_stats.var();
  e.obs_clip = obs_stats.clip;
  e.obs_epsilon = obs_stats.epsilon;
  const nn::MLP& policy = model.policy();
  for (std::size_t i = 0; i < policy.num_layers(); ++i) {
    const std::string prefix = "layers." + std::to_string(i) + ".";
    e.weights.push_back(ag::to_eigen_double(policy.parameter(prefix + "weight")));
    e.biases.push_back(to_vector_d(policy.parameter(prefix + "bias")));
  }
  e.log_std = to_vector_d(model.log_std());
  e.metadata_json = metadata_json;
  return e;
}

std::vector<double> evaluate_policy(envs::Env& env, ActorCritic& model, const RunningMeanStd& obs_stats, int episodes,
                                    std::uint64_t first_seed, std::vector<std::vector<double>>* pitches,
                                    int pitch_index) {
  std::vector<double> returns;
  if (pitches) pitches->clear();
  for (int e = 0; e < episodes; ++e) {
    Eigen::VectorXd obs = env.reset(first_seed + static_cast<std::uint64_t>(e));
    std::vector<double> episode_pitches;
    double total = 0.0;
    for (;;) {
      if (pitches) episode_pitches.push_back(obs(pitch_index));
      const envs::StepResult res = env.step(clip_to_bounds(mean_action_of(model, obs_stats, obs), env.spec()));
      total += res.reward;
      obs = res.observation;
      if (res.done()) break;
    }
    returns.push_back(total);
    if (pitches) pitches->push_back(std::move(episode_pitches));
  }
  return returns;
}

}  // namespace maps::rl
