#include "maps/training/trainer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <optional>
#include <ostream>
#include <random>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "autograd/float_environment.h"
#include "autograd/matmul_precision.h"
#include "envs/portable_random.h"
#include "maps/training/checkpoint_record.h"
#include "maps/training/curve_file.h"
#include "maps/training/run_files.h"
#include "maps/training/weight_average.h"
#include "nn/optim/adam.h"
#include "nn/serialize.h"

namespace maps::core {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;

constexpr const char* kPolicyPrefix = kTrainingStatePolicyPrefix;
constexpr const char* kAdamPrefix = kTrainingStateAdamPrefix;
constexpr const char* kAveragePrefix = kTrainingStateAveragePrefix;

struct Progress {
  std::int64_t step = 0;
  std::int64_t best_step = -1;
  double best_validation = INFINITY;
};

void save_last(const std::string& path, const Policy& policy, const optim::Adam& adam, const WeightAverage* average,
               const Progress& progress, const std::mt19937_64& rng) {
  nn::NamedTensors tensors;
  nn::append_with_prefix(tensors, policy.state_dict(), kPolicyPrefix);
  nn::append_with_prefix(tensors, adam.state(), kAdamPrefix);
  if (average != nullptr) nn::append_with_prefix(tensors, average->values(), kAveragePrefix);
  std::ostringstream rng_text;
  rng_text << rng;
  TrainingState state;
  state.step = progress.step;
  state.best_step = progress.best_step;
  state.best_validation = progress.best_validation;
  state.rng = rng_text.str();
  if (average != nullptr) {
    state.ema_power = average->power();
    state.ema_max_decay = average->max_decay();
  }
  nn::save_tensors(path, tensors, to_json(state).dump());
}

Progress load_last(const std::string& path, Policy& policy, optim::Adam& adam, WeightAverage* average,
                   std::mt19937_64& rng) {
  const nn::Checkpoint checkpoint = nn::load_tensors(path);
  const TrainingState state = read_training_state(checkpoint.config, "training checkpoint " + path);
  const nn::NamedTensors averaged = nn::strip_prefix(checkpoint.tensors, kAveragePrefix);
  check_average_agrees(path, state, !averaged.empty(), average != nullptr ? average->power() : 0.0,
                       average != nullptr ? average->max_decay() : 0.0, "this run", AverageUse::kResume);
  try {
    policy.load_state_dict(nn::strip_prefix(checkpoint.tensors, kPolicyPrefix));
    adam.load_state(nn::strip_prefix(checkpoint.tensors, kAdamPrefix));
    if (average != nullptr) average->load(averaged, "training checkpoint " + path);
  } catch (const std::exception& e) {
    throw std::runtime_error("training checkpoint " + path + " does not fit this policy: " + e.what());
  }
  Progress progress;
  progress.step = state.step;
  progress.best_step = state.best_step;
  progress.best_validation = state.best_validation;
  std::istringstream rng_text(state.rng);
  rng_text >> rng;
  if (rng_text.fail()) throw std::runtime_error("training checkpoint " + path + ": unreadable RNG state");
  return progress;
}

std::string format_seconds(double seconds) {
  const auto s = static_cast<long long>(seconds);
  char text[32];
  std::snprintf(text, sizeof text, "%lldm%02llds", s / 60, s % 60);
  return text;
}

// What best.ckpt and step_<N>.ckpt say of the policy they hold (checkpoint_record.h).
Json policy_record(const DemoDataset& data, std::int64_t step, std::optional<double> validation_bc) {
  PolicyRecord record;
  record.step = step;
  record.validation_bc = validation_bc;
  record.standardizer = data.standardizer();
  return to_json(record);
}

bool starts_with(const std::string& name, const std::string& prefix) { return name.rfind(prefix, 0) == 0; }

// The parameters train.freeze leaves to Adam, each with train.lr_scale's factor. Frozen parameters stop requiring
// gradients, so backward spends nothing on them and they stay bit for bit as loaded. A prefix that names no
// parameter is an error listing the names (a typo must not silently train everything).
struct TrainedParameters {
  std::vector<ag::Tensor> tensors;
  std::vector<double> lr_scales;
  std::vector<bool> selector;  // the name starts with "selector" (train.optimizer "alternating" steps these first)
};
TrainedParameters trained_parameters(Policy& policy, const TrainConfig& config) {
  const nn::NamedTensors named = policy.named_parameters();
  auto check_prefix = [&](const std::string& prefix, const char* key) {
    for (const auto& p : named)
      if (starts_with(p.name, prefix)) return;
    std::string names;
    for (const auto& p : named) names += (names.empty() ? "" : ", ") + p.name;
    throw std::invalid_argument("train." + std::string(key) + ": '" + prefix + "' starts no parameter name of this " +
                                policy.type_name() + " (" + names + ")");
  };
  for (const auto& prefix : config.freeze) check_prefix(prefix, "freeze");
  for (const auto& [prefix, scale] : config.lr_scale) check_prefix(prefix, "lr_scale");
  TrainedParameters trained;
  for (const auto& p : named) {
    if (std::any_of(config.freeze.begin(), config.freeze.end(),
                    [&](const std::string& prefix) { return starts_with(p.name, prefix); })) {
      ag::Tensor frozen = p.tensor;
      frozen.requires_grad_(false);
      continue;
    }
    trained.tensors.push_back(p.tensor);
    trained.selector.push_back(starts_with(p.name, "selector"));
    double scale = 1.0;
    for (const auto& [prefix, factor] : config.lr_scale)
      if (starts_with(p.name, prefix)) {
        scale = factor;
        break;
      }
    trained.lr_scales.push_back(scale);
  }
  if (trained.tensors.empty()) throw std::invalid_argument("train.freeze: every parameter is frozen, nothing to train");
  if (config.optimizer == "alternating") {
    const auto selectors = std::count(trained.selector.begin(), trained.selector.end(), true);
    if (selectors == 0 || selectors == static_cast<std::ptrdiff_t>(trained.selector.size()))
      throw std::invalid_argument(
          "train.optimizer \"alternating\" steps the selector's parameters, then the others, but this " +
          policy.type_name() + " trains " + (selectors == 0 ? "no parameter named selector..." : "only the selector") +
          "; use \"joint\"");
  }
  return trained;
}

// One pass of an alternating step: only one side's parameters (the selector's or the others) require gradients
// while the loss is built and differentiated, so backward spends nothing on the other side's weights; Adam then
// steps the parameters that got a gradient (it skips those without). A non-finite loss steps nothing.
LossTerms one_side_pass(Policy& policy, const Batch& batch, const std::vector<ag::Tensor>& params,
                        const std::vector<bool>& selector, optim::Adam& adam, bool selector_side) {
  for (std::size_t i = 0; i < params.size(); ++i) {
    ag::Tensor p = params[i];
    p.requires_grad_(selector[i] == selector_side);
  }
  LossTerms terms = policy.loss(batch);
  adam.zero_grad();
  if (std::isfinite(terms.total.item())) {
    terms.total.backward();
    adam.step();
  }
  for (ag::Tensor p : params) p.requires_grad_(true);
  return terms;
}

}  // namespace

LossTerms optimizer_step(Policy& policy, Batch& batch, const std::vector<ag::Tensor>& params,
                         const std::vector<bool>& selector, optim::Adam& adam, const std::string& optimizer) {
  if (optimizer == "joint") {
    LossTerms terms = policy.loss(batch);
    if (!std::isfinite(terms.total.item())) return terms;
    adam.zero_grad();
    terms.total.backward();
    adam.step();
    return terms;
  }
  if (optimizer != "alternating")
    throw std::invalid_argument("train.optimizer: expected \"joint\" or \"alternating\", got \"" + optimizer + "\"");
  if (selector.size() != params.size())
    throw std::invalid_argument("optimizer_step: " + std::to_string(selector.size()) + " selector flags for " +
                                std::to_string(params.size()) + " parameters");
  LossTerms first = one_side_pass(policy, batch, params, selector, adam, true);
  if (!std::isfinite(first.total.item())) return first;
  batch.noise_seed = envs::splitmix64(batch.noise_seed ^ 0x7365636f6e64ULL);  // "second": a fresh noise draw
  LossTerms second = one_side_pass(policy, batch, params, selector, adam, false);
  // A loss that only the stepped selector made non-finite is reported as this step's.
  return std::isfinite(second.total.item()) ? first : second;
}

std::int64_t trained_steps(const std::string& run_dir) {
  const std::string last_path = (fs::path(run_dir) / run_files::kLastCheckpoint).string();
  if (!fs::exists(last_path)) return 0;
  return read_training_state(nn::load_tensors(last_path).config, "training checkpoint " + last_path).step;
}

TrainSummary train_policy(Policy& policy, const DemoDataset& data, const TrainConfig& config,
                          const std::string& run_dir, std::ostream* log) {
  if (config.steps < 1 || config.states_per_task < 1 || config.validate_every < 1 || config.checkpoint_every < 1)
    throw std::invalid_argument("train: steps, states_per_task, validate_every and checkpoint_every must be >= 1");
  if (config.keep_every < 0)
    throw std::invalid_argument("train: keep_every must be >= 0 (0: keep no step checkpoints)");
  const ag::MatmulPrecision precision = ag::parse_matmul_precision(config.precision);
  if (const std::string refusal = ag::matmul_precision_refusal(precision); !refusal.empty())
    throw std::invalid_argument("train.precision \"" + config.precision + "\" " + refusal + " (use \"float32\")");
  fs::create_directories(run_dir);
  const ag::FlushDenormalGuard flush(config.flush_denormal);
  const std::string last_path = (fs::path(run_dir) / run_files::kLastCheckpoint).string();
  const std::string best_path = (fs::path(run_dir) / run_files::kBestCheckpoint).string();
  const std::string curve_path = (fs::path(run_dir) / run_files::kCurve).string();

  policy.train();
  policy.set_observation_statistics(data.standardizer().mean, data.standardizer().std);
  const TrainedParameters trained = trained_parameters(policy, config);
  optim::Adam adam(trained.tensors, {.lr = config.learning_rate, .eps = config.adam_eps});
  for (std::size_t i = 0; i < trained.lr_scales.size(); ++i) adam.set_lr_scale(i, trained.lr_scales[i]);
  std::mt19937_64 rng(envs::splitmix64(config.seed ^ 0x6261746368657321ULL));  // "batches!"
  // A function of the seed and the step, so a resumed run draws the same noise without saving a generator.
  const std::uint64_t noise_stream = envs::splitmix64(config.seed ^ 0x6e6f697365ULL);  // "noise"
  std::optional<WeightAverage> average;
  if (config.ema_power != 0.0) average.emplace(policy.named_parameters(), config.ema_power, config.ema_max_decay);
  WeightAverage* const averaged = average ? &*average : nullptr;
  Progress progress;
  TrainSummary summary;
  if (fs::exists(last_path)) {
    progress = load_last(last_path, policy, adam, averaged, rng);
    if (progress.step > config.steps)
      throw std::invalid_argument(last_path + " has trained " + std::to_string(progress.step) +
                                  " steps, more than train.steps " + std::to_string(config.steps) +
                                  ": a run can be extended, not shortened (best.ckpt and curve.csv stay as they are)");
    summary.resumed = true;
    truncate_curve(curve_path, progress.step);
    if (log) *log << "resumed from " << last_path << " at step " << progress.step << std::endl;
  } else {
    std::ofstream(curve_path, std::ios::trunc);  // a fresh run starts a fresh curve
  }
  const Batch validation =
      data.validation_batch(ag::Dtype::Float32, config.validation_states_per_task, config.validation_tasks);
  const std::int64_t per_task = policy.batch_per_task(config.states_per_task);

  // Scores the policy at progress.step on the validation states and keeps it as best.ckpt when it beats the best so
  // far (never for a NaN loss).
  const auto seconds_since = [](std::chrono::steady_clock::time_point from) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - from).count();
  };
  const auto validate_and_keep_best = [&] {
    const WeightAverage::Applied judged(averaged);  // with train.ema_power, the average is judged and kept
    const auto validation_start = std::chrono::steady_clock::now();
    const double valid = policy.validation_loss(validation, data);
    policy.train();
    summary.validation_seconds += seconds_since(validation_start);
    ++summary.validations;
    if (valid < progress.best_validation) {
      const auto save_start = std::chrono::steady_clock::now();
      progress.best_validation = valid;
      progress.best_step = progress.step;
      nn::save(policy, best_path, policy_record(data, progress.step, valid).dump());
      summary.checkpoint_seconds += seconds_since(save_start);
      ++summary.checkpoints_written;
    }
    return valid;
  };
  const auto start = std::chrono::steady_clock::now();
  if (config.validate_start && !summary.resumed && progress.step == 0) {
    const double valid = validate_and_keep_best();
    if (log) *log << "step 0/" << config.steps << "  (the starting parameters)  valid " << valid << std::endl;
  }

  std::vector<std::string> term_names;
  std::vector<double> term_sums;
  std::int64_t terms_counted = 0;
  auto window_start = std::chrono::steady_clock::now();
  std::int64_t window_first_step = progress.step;
  const bool cpu_column = curve_has_cpu_column(curve_path);
  double window_cpu_start = process_cpu_seconds();
  while (progress.step < config.steps) {
    Batch batch = data.sample(per_task, rng, ag::Dtype::Float32);
    batch.noise_seed = envs::splitmix64(noise_stream ^ static_cast<std::uint64_t>(progress.step));
    const LossTerms terms = [&] {
      // The step only: validation judges checkpoints with the float32 products evaluation runs.
      const ag::MatmulPrecisionGuard step_precision(precision);
      return optimizer_step(policy, batch, trained.tensors, trained.selector, adam, config.optimizer);
    }();
    const double total = terms.total.item();
    if (!std::isfinite(total)) {
      std::string culprit = "total";
      for (const auto& [name, value] : terms.terms)
        if (!std::isfinite(value.item())) culprit = name;
      throw std::runtime_error("training stopped at step " + std::to_string(progress.step + 1) + ": the loss '" +
                               culprit + "' is not finite; " +
                               (fs::exists(last_path) ? last_path + " holds the last good checkpoint"
                                                      : std::string("no checkpoint was written yet")));
    }
    policy.after_step();
    ++progress.step;
    if (averaged != nullptr) averaged->update(progress.step);
    if (term_names.empty()) {
      for (const auto& [name, value] : terms.terms) term_names.push_back(name);
      term_names.push_back("total");
      term_sums.assign(term_names.size(), 0.0);
      if (std::ifstream(curve_path).peek() == std::ifstream::traits_type::eof()) {
        std::ofstream curve(curve_path, std::ios::app);
        curve << "step";
        for (const auto& name : term_names) curve << "," << name;
        curve << ",validation_bc,steps_per_second" << (cpu_column ? ",cpu_seconds" : "") << "\n";
        if (!curve.flush()) throw std::runtime_error("cannot append to " + curve_path);
      }
    }
    for (std::size_t j = 0; j + 1 < term_names.size(); ++j) term_sums[j] += terms.terms[j].second.item();
    term_sums.back() += total;
    ++terms_counted;

    const bool last_step = progress.step == config.steps;
    if (progress.step % config.validate_every == 0 || last_step) {
      const double valid = validate_and_keep_best();
      const auto now = std::chrono::steady_clock::now();
      const double window = std::chrono::duration<double>(now - window_start).count();
      const double steps_per_second = static_cast<double>(progress.step - window_first_step) / std::max(window, 1e-9);
      std::ofstream curve(curve_path, std::ios::app);
      curve << progress.step;
      for (double sum : term_sums) curve << "," << sum / static_cast<double>(terms_counted);
      curve << "," << valid << "," << steps_per_second;
      const double cpu_now = process_cpu_seconds();
      if (cpu_column) curve << "," << cpu_now - window_cpu_start;
      curve << "\n";
      // A row that cannot be written stops the run (last.ckpt keeps its progress) instead of a curve with a gap.
      if (!curve.flush()) throw std::runtime_error("cannot append to " + curve_path);
      window_cpu_start = cpu_now;
      if (log) {
        std::ostringstream line;
        line.precision(4);
        line << "step " << progress.step << "/" << config.steps << "  loss " << term_sums.back() / terms_counted
             << " (";
        for (std::size_t j = 0; j + 1 < term_names.size(); ++j)
          line << (j ? " " : "") << term_names[j] << " " << term_sums[j] / terms_counted;
        line << ")  valid " << valid << " (best " << progress.best_validation << " @" << progress.best_step << ")  "
             << static_cast<long long>(steps_per_second) << " steps/s  eta "
             << format_seconds(static_cast<double>(config.steps - progress.step) / std::max(steps_per_second, 1e-9));
        *log << line.str() << std::endl;
      }
      std::fill(term_sums.begin(), term_sums.end(), 0.0);
      terms_counted = 0;
      window_start = now;
      window_first_step = progress.step;
    }
    const bool keep = config.keep_every > 0 && progress.step % config.keep_every == 0;
    const bool save = progress.step % config.checkpoint_every == 0 || last_step;
    if (keep || save) {
      const auto save_start = std::chrono::steady_clock::now();
      if (keep) {
        const WeightAverage::Applied kept_average(averaged);
        const std::string kept = (fs::path(run_dir) / run_files::kept_checkpoint(progress.step)).string();
        nn::save(policy, kept, policy_record(data, progress.step, std::nullopt).dump());
      }
      if (save) save_last(last_path, policy, adam, averaged, progress, rng);
      summary.checkpoint_seconds += seconds_since(save_start);
      summary.checkpoints_written += (keep ? 1 : 0) + (save ? 1 : 0);
    }
  }
  summary.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  summary.steps_done = progress.step;
  summary.best_step = progress.best_step;
  summary.best_validation_loss = progress.best_validation;
  if (fs::exists(best_path)) nn::load(policy, best_path);
  policy.eval();
  return summary;
}

}  // namespace maps::core
