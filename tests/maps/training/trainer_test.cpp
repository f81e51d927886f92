#include "maps/training/trainer.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>

#include "envs/portable_random.h"
#include "maps/policies/maps_policy.h"
#include "maps/policies/mt_bc.h"
#include "maps/training/curve_cost.h"
#include "maps/training/run_config.h"
#include "nn/serialize.h"
#include "tests/common/error_of.h"
#include "tests/common/scratch_path.h"
#include "tests/maps/data/synthetic_demos.h"

namespace maps::core {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

fs::path fresh_dir(const std::string& name) { return scratch_path("maps_trainer_test_" + name); }

TrainConfig small_config() {
  TrainConfig c;
  c.steps = 60;
  c.states_per_task = 16;
  c.validate_every = 20;
  c.checkpoint_every = 20;
  c.seed = 5;
  return c;
}

std::shared_ptr<Policy> small_maps(std::uint64_t seed) {
  ag::Generator gen(seed);
  MAPSConfig config;
  config.modules = 3;
  config.module_hidden = {16};
  config.selector_hidden = {8};
  return std::make_shared<MAPSPolicy>(PolicyShape{3, 2, 2}, config, gen);
}

// A run folder stopped after 40 of small_config()'s 60 steps, as a killed run leaves it at its last checkpoint.
fs::path trained_40_of_60_steps(const DemoDataset& data, const std::string& name) {
  const fs::path dir = fresh_dir(name);
  TrainConfig partial = small_config();
  partial.steps = 40;
  train_policy(*small_maps(2), data, partial, dir.string(), nullptr);
  return dir;
}

std::vector<double> parameters_of(const Policy& policy) {
  std::vector<double> out;
  for (const auto& p : policy.parameters())
    for (double v : p.to_vector()) out.push_back(v);
  return out;
}

TEST(Trainer, LearnsKeepsTheBestCheckpointAndWritesTheCurve) {
  const DemoDataset data(synthetic_demo_file(), DataConfig{});
  auto policy = small_maps(1);
  const Batch validation = data.validation_batch(ag::Dtype::Float32);
  const double before = mean_action_error(*policy, validation);
  const fs::path dir = fresh_dir("learns");
  TrainConfig config = small_config();
  config.steps = 200;
  config.learning_rate = 3e-3;
  const TrainSummary summary = train_policy(*policy, data, config, dir.string(), nullptr);
  EXPECT_EQ(summary.steps_done, 200);
  EXPECT_LT(summary.best_validation_loss, 0.5 * before);
  // The policy left in memory is the best checkpoint's.
  EXPECT_NEAR(mean_action_error(*policy, validation), summary.best_validation_loss, 1e-6);
  std::ifstream curve(dir / "curve.csv");
  std::string header;
  std::getline(curve, header);
  EXPECT_EQ(header, "step,bc,share,explore,sparse,smooth,total,validation_bc,steps_per_second,cpu_seconds");
  int rows = 0;
  for (std::string line; std::getline(curve, line);) {
    ++rows;
    const double cpu_seconds = std::stod(line.substr(line.rfind(',') + 1));
    EXPECT_GT(cpu_seconds, 0.0) << line;
    EXPECT_LT(cpu_seconds, 60.0) << line;  // one window's CPU time, not the process's total
  }
  EXPECT_EQ(rows, 10);
  const auto best = nlohmann::json::parse(nn::load_tensors((dir / "best.ckpt").string()).config);
  EXPECT_EQ(best.at("step").get<std::int64_t>(), summary.best_step);
  EXPECT_EQ(best.at("standardizer").at("mean").size(), 3u);
}

TEST(Trainer, ValidateStartMakesTheStartingParametersACandidateForTheBestCheckpoint) {
  const DemoDataset data(synthetic_demo_file(), DataConfig{});
  // Learning rate 0: every validation scores the start again, so the first one judged stays the best (strict <).
  TrainConfig config = small_config();
  config.learning_rate = 0.0;
  config.validate_start = true;
  auto policy = small_maps(1);
  const std::vector<double> start = parameters_of(*policy);
  const fs::path dir = fresh_dir("validate_start");
  const TrainSummary summary = train_policy(*policy, data, config, dir.string(), nullptr);
  EXPECT_EQ(summary.best_step, 0);
  const Batch validation = data.validation_batch(ag::Dtype::Float32);
  EXPECT_NEAR(summary.best_validation_loss, mean_action_error(*small_maps(1), validation), 1e-6);
  const auto best = nlohmann::json::parse(nn::load_tensors((dir / "best.ckpt").string()).config);
  EXPECT_EQ(best.at("step").get<std::int64_t>(), 0);
  auto reloaded = small_maps(9);
  nn::load(*reloaded, (dir / "best.ckpt").string());
  EXPECT_EQ(parameters_of(*reloaded), start);
  // Step 0 has no training losses, so no curve row: the rows are the trained steps' as without the option.
  std::ifstream curve(dir / "curve.csv");
  std::string header, first;
  std::getline(curve, header);
  std::getline(curve, first);
  EXPECT_EQ(first.substr(0, first.find(',')), "20");
  // Without the option the first validated step is the best a run can keep.
  config.validate_start = false;
  EXPECT_EQ(train_policy(*small_maps(1), data, config, fresh_dir("no_validate_start").string(), nullptr).best_step, 20);
}

TEST(Trainer, TimesValidationAndCheckpointWritesApartFromTheSteps) {
  const DemoDataset data(synthetic_demo_file(), DataConfig{});
  // Learning rate 0: the start stays the best, so best.ckpt is written once (at step 0).
  TrainConfig config = small_config();
  config.learning_rate = 0.0;
  config.validate_start = true;
  config.keep_every = 30;
  const TrainSummary summary = train_policy(*small_maps(1), data, config, fresh_dir("overheads").string(), nullptr);
  EXPECT_EQ(summary.validations, 4);  // steps 0, 20, 40, 60
  // best.ckpt once, last.ckpt at 20, 40 and 60, step_30 and step_60 kept.
  EXPECT_EQ(summary.checkpoints_written, 6);
  EXPECT_GT(summary.validation_seconds, 0.0);
  EXPECT_GT(summary.checkpoint_seconds, 0.0);
  EXPECT_LT(summary.validation_seconds + summary.checkpoint_seconds, summary.seconds);
}

TEST(Trainer, AStartWhoseValidationIsNotFiniteIsNeverKeptAndTrainingStopsWithTheReason) {
  const DemoDataset data(synthetic_demo_file(), DataConfig{});
  TrainConfig config = small_config();
  config.validate_start = true;
  auto policy = small_maps(1);
  ag::Tensor w = policy->parameter("head.weight");
  w.data<float>()[0] = std::numeric_limits<float>::quiet_NaN();
  const fs::path dir = fresh_dir("validate_start_nan");
  EXPECT_THAT(error_of([&] { train_policy(*policy, data, config, dir.string(), nullptr); }),
              HasSubstr("training stopped at step 1"));
  // A NaN validation loss is not "lower" than no checkpoint: best.ckpt is never written from it.
  EXPECT_FALSE(fs::exists(dir / "best.ckpt"));
}

TEST(Trainer, JudgesCheckpointsOnTheValidationTasksItIsGiven) {
  const DemoDataset data(synthetic_demo_file(), DataConfig{});
  TrainConfig config = small_config();
  config.steps = 60;
  config.learning_rate = 3e-3;
  config.validation_tasks = {"synthetic/b"};
  auto policy = small_maps(1);
  const fs::path dir = fresh_dir("validation_tasks");
  const TrainSummary summary = train_policy(*policy, data, config, dir.string(), nullptr);
  // The recorded best loss is b's alone, not the two tasks' mean.
  const Batch b = data.validation_batch(ag::Dtype::Float32, config.validation_states_per_task, {"synthetic/b"});
  const Batch both = data.validation_batch(ag::Dtype::Float32, config.validation_states_per_task);
  EXPECT_NEAR(mean_action_error(*policy, b), summary.best_validation_loss, 1e-6);
  EXPECT_GT(std::abs(mean_action_error(*policy, both) - summary.best_validation_loss), 1e-6);
  config.validation_tasks = {"synthetic/z"};
  auto other = small_maps(1);
  EXPECT_THAT(error_of([&] { train_policy(*other, data, config, fresh_dir("bad_validation").string(), nullptr); }),
              HasSubstr("train.validation_tasks: 'synthetic/z' is not a task of this run"));
}

TEST(Trainer, AResumedRunEndsExactlyWhereAnUninterruptedOneDoes) {
  const DemoDataset data(synthetic_demo_file(), DataConfig{});
  auto straight = small_maps(2);
  const fs::path a = fresh_dir("straight"), b = fresh_dir("resumed");
  TrainConfig config = small_config();
  train_policy(*straight, data, config, a.string(), nullptr);
  // Stop after 40 steps (a process that ended), then a new process with the full budget resumes.
  auto first = small_maps(2);
  TrainConfig partial = config;
  partial.steps = 40;
  train_policy(*first, data, partial, b.string(), nullptr);
  auto second = small_maps(99);  // a different initialisation: every value must come from the checkpoint
  const TrainSummary summary = train_policy(*second, data, config, b.string(), nullptr);
  EXPECT_TRUE(summary.resumed);
  // Both last checkpoints (policy, Adam moments, step, RNG) are identical.
  const auto ca = nn::load_tensors((a / "last.ckpt").string()), cb = nn::load_tensors((b / "last.ckpt").string());
  ASSERT_EQ(ca.tensors.size(), cb.tensors.size());
  for (std::size_t i = 0; i < ca.tensors.size(); ++i)
    EXPECT_EQ(ca.tensors[i].tensor.to_vector(), cb.tensors[i].tensor.to_vector()) << ca.tensors[i].name;
  EXPECT_EQ(parameters_of(*straight), parameters_of(*second));
  // The resumed curve has each validation row once.
  std::ifstream curve(b / "curve.csv");
  int rows = -1;
  for (std::string line; std::getline(curve, line);) ++rows;
  EXPECT_EQ(rows, 3);
}

TEST(Trainer, ResumingDropsCurveRowsPastTheCheckpointAndRowsCutShort) {
  // A kill after a validation row but before its checkpoint leaves a row the resumed run writes again; a kill in the
  // middle of an append leaves a row cut short. Neither may stay, and the rows before them must.
  const DemoDataset data(synthetic_demo_file(), DataConfig{});
  const fs::path dir = trained_40_of_60_steps(data, "cut_curve");
  {
    std::ofstream out(dir / "curve.csv", std::ios::app);
    out << "60,1,2,3,4,5,6,7,8,9\n"
        << "6";  // cut short: no newline, one column
  }
  train_policy(*small_maps(2), data, small_config(), dir.string(), nullptr);
  std::ifstream curve(dir / "curve.csv");
  std::vector<std::string> steps;
  for (std::string line; std::getline(curve, line);) steps.push_back(line.substr(0, line.find(',')));
  EXPECT_THAT(steps, ::testing::ElementsAre("step", "20", "40", "60"));
  // The rewrite went through a temporary that is gone.
  for (const auto& entry : fs::directory_iterator(dir))
    EXPECT_EQ(entry.path().filename().string().find("tmp"), std::string::npos) << entry.path();
}

TEST(Trainer, TheCurveCostsEveryAttemptOfAResumedRun) {
  // 40 steps in one process, 20 more in the next: the curve's cost holds both, where the second process's clock has
  // its own.
  const DemoDataset data(synthetic_demo_file(), DataConfig{});
  const fs::path dir = trained_40_of_60_steps(data, "curve_cost");
  const auto first = curve_training_cost((dir / "curve.csv").string(), 40);
  ASSERT_TRUE(first.has_value());
  EXPECT_TRUE(first->cpu);
  EXPECT_GT(first->seconds, 0.0);
  ASSERT_TRUE(train_policy(*small_maps(2), data, small_config(), dir.string(), nullptr).resumed);
  const auto both = curve_training_cost((dir / "curve.csv").string(), 60);
  ASSERT_TRUE(both.has_value());
  EXPECT_GT(both->seconds, first->seconds);
  // The resume kept the first attempt's rows as they were.
  EXPECT_DOUBLE_EQ(curve_training_cost((dir / "curve.csv").string(), 40)->seconds, first->seconds);
}

TEST(Trainer, ResumingACurveWithoutTheCpuColumnKeepsItsColumns) {
  // A run begun by a build from before curve.csv had cpu_seconds, resumed by this one: every row as wide as its header.
  const DemoDataset data(synthetic_demo_file(), DataConfig{});
  const fs::path dir = trained_40_of_60_steps(data, "old_curve");
  std::vector<std::string> lines;
  {
    std::ifstream in(dir / "curve.csv");
    for (std::string line; std::getline(in, line);) lines.push_back(line.substr(0, line.rfind(',')));
  }
  ASSERT_EQ(lines.front(), "step,bc,share,explore,sparse,smooth,total,validation_bc,steps_per_second");
  {
    std::ofstream out(dir / "curve.csv", std::ios::trunc);
    for (const auto& line : lines) out << line << "\n";
  }
  train_policy(*small_maps(2), data, small_config(), dir.string(), nullptr);
  std::ifstream curve(dir / "curve.csv");
  int rows = 0;
  for (std::string line; std::getline(curve, line); ++rows)
    EXPECT_EQ(std::count(line.begin(), line.end(), ','), 8) << line;
  EXPECT_EQ(rows, 1 + 3);
}

TEST(Trainer, TrainsInTheDenormalModeItsConfigSaysAndRestoresTheCallers) {
  if (!ag::flush_denormal_supported()) GTEST_SKIP() << "this CPU cannot flush denormals";
  const DemoDataset data(synthetic_demo_file(), DataConfig{});
  const bool callers = ag::set_flush_denormal(false);
  for (const bool flush : {true, false}) {
    // A policy that records the mode its loss is computed in.
    struct Recording : MAPSPolicy {
      using MAPSPolicy::MAPSPolicy;
      LossTerms loss(const Batch& batch) override {
        modes.push_back(ag::flush_denormal());
        return MAPSPolicy::loss(batch);
      }
      std::vector<bool> modes;
    };
    ag::Generator gen(3);
    MAPSConfig maps_config;
    maps_config.modules = 2;
    maps_config.module_hidden = {8};
    maps_config.selector_hidden = {4};
    Recording policy(PolicyShape{3, 2, 2}, maps_config, gen);
    TrainConfig config = small_config();
    config.steps = 5;
    config.flush_denormal = flush;
    train_policy(policy, data, config, fresh_dir(flush ? "flush" : "ieee").string(), nullptr);
    ASSERT_EQ(policy.modes.size(), 5u);
    for (const bool mode : policy.modes) EXPECT_EQ(mode, flush);
    EXPECT_FALSE(ag::flush_denormal());
  }
  ag::set_flush_denormal(callers);
  nlohmann::json request = nlohmann::json::parse(R"({"method": "mt_bc", "data": {"file": "x.h5"}})");
  EXPECT_TRUE(parse_run_config(request).train.flush_denormal);
  request["train"]["flush_denormal"] = false;
  EXPECT_FALSE(parse_run_config(request).train.flush_denormal);
  EXPECT_FALSE(to_json(parse_run_config(request))["train"]["flush_denormal"].get<bool>());
  request["train"]["flush_denormal"] = 0;
  EXPECT_THAT(error_of([&] { parse_run_config(request); }),
              HasSubstr("train.flush_denormal: expected true or false, got 0"));
}

TEST(Trainer, ANonFiniteLossStopsWithTheStepAndTheTermAndKeepsTheLastCheckpoint) {
  const DemoDataset data(synthetic_demo_file(), DataConfig{});
  auto policy = small_maps(3);
  const fs::path dir = fresh_dir("nan");
  TrainConfig config = small_config();
  config.steps = 20;
  train_policy(*policy, data, config, dir.string(), nullptr);
  // Poison one weight: the next forward gives NaN.
  ag::Tensor w = policy->parameter("head.weight");
  w.data<float>()[0] = std::numeric_limits<float>::quiet_NaN();
  const auto before = nn::load_tensors((dir / "last.ckpt").string());
  config.steps = 40;
  nn::save_tensors((dir / "poisoned.ckpt").string(), policy->state_dict());
  fs::remove(dir / "last.ckpt");
  EXPECT_THAT([&] { train_policy(*policy, data, config, dir.string(), nullptr); },
              ::testing::ThrowsMessage<std::runtime_error>(
                  ::testing::AllOf(HasSubstr("training stopped at step 1"), HasSubstr("'bc' is not finite"))));
  nn::save_tensors((dir / "last.ckpt").string(), before.tensors, before.config);
  auto fresh = small_maps(4);
  const TrainSummary summary = train_policy(*fresh, data, config, dir.string(), nullptr);
  EXPECT_TRUE(summary.resumed);
  EXPECT_TRUE(std::isfinite(summary.best_validation_loss));
}

// Parameter i of a policy: whether it is the selector's (its name starts with "selector").
std::vector<bool> selector_flags(const Policy& policy) {
  std::vector<bool> flags;
  for (const auto& p : policy.named_parameters()) flags.push_back(p.name.rfind("selector", 0) == 0);
  return flags;
}

std::vector<ag::Tensor> side(const Policy& policy, bool selector_side) {
  std::vector<ag::Tensor> out;
  const auto flags = selector_flags(policy);
  const auto params = policy.parameters();
  for (std::size_t i = 0; i < params.size(); ++i)
    if (flags[i] == selector_side) out.push_back(params[i]);
  return out;
}

TEST(Trainer, AlternatingStepsTheSelectorThenTheRestOnTheLossAfterTheSelectorsStep) {
  const DemoDataset data(synthetic_demo_file(), DataConfig{});
  std::mt19937_64 rng(3);
  Batch batch = data.sample(16, rng, ag::Dtype::Float32);
  batch.noise_seed = 11;
  auto alternating = small_maps(4), by_hand = small_maps(4), joint = small_maps(4);
  // The paper's sampled BC loss, so that the second pass's fresh noise draw is part of what is checked.
  for (auto* policy : {alternating.get(), by_hand.get(), joint.get()}) {
    policy->set_observation_statistics(data.standardizer().mean, data.standardizer().std);
    policy->use_sampled_bc_loss();
  }
  const auto flags = selector_flags(*alternating);
  ASSERT_GT(std::count(flags.begin(), flags.end(), true), 0);
  ASSERT_GT(std::count(flags.begin(), flags.end(), false), 0);
  // eps 1: a first Adam step is then about lr * g, so the check sees the gradients, not only their signs.
  const optim::AdamOptions options{.lr = 1e-2, .eps = 1.0};

  optim::Adam adam(alternating->parameters(), options);
  Batch a = batch;
  const double before =
      optimizer_step(*alternating, a, alternating->parameters(), flags, adam, "alternating").total.item();
  // By hand, two Adams: the selector's on the loss, then the others' on the loss recomputed after it.
  optim::Adam selector_adam(side(*by_hand, true), options), rest_adam(side(*by_hand, false), options);
  LossTerms first = by_hand->loss(batch);
  EXPECT_EQ(first.total.item(), before);
  first.total.backward();
  selector_adam.step();
  rest_adam.zero_grad();
  Batch redrawn = batch;
  redrawn.noise_seed = envs::splitmix64(batch.noise_seed ^ 0x7365636f6e64ULL);  // optimizer_step's second draw
  LossTerms second = by_hand->loss(redrawn);
  selector_adam.zero_grad();
  rest_adam.zero_grad();
  second.total.backward();
  rest_adam.step();
  const auto got = alternating->named_parameters(), want = by_hand->named_parameters();
  for (std::size_t i = 0; i < got.size(); ++i) {
    const auto g = got[i].tensor.to_vector(), w = want[i].tensor.to_vector();
    ASSERT_EQ(g.size(), w.size());
    for (std::size_t j = 0; j < g.size(); ++j) ASSERT_NEAR(g[j], w[j], 1e-6) << got[i].name << "[" << j << "]";
  }
  // Every parameter requires its gradient again afterwards.
  for (const auto& p : alternating->parameters()) EXPECT_TRUE(p.requires_grad());
  // A joint step differs in the modules and head (their gradient is taken before the selector moved).
  optim::Adam joint_adam(joint->parameters(), options);
  Batch j = batch;
  optimizer_step(*joint, j, joint->parameters(), flags, joint_adam, "joint");
  const auto stepped = side(*alternating, false), jointly = side(*joint, false);
  double largest = 0.0;
  for (std::size_t i = 0; i < stepped.size(); ++i) {
    const auto x = stepped[i].to_vector(), y = jointly[i].to_vector();
    for (std::size_t k = 0; k < x.size(); ++k) largest = std::max(largest, std::abs(x[k] - y[k]));
  }
  EXPECT_GT(largest, 1e-7);
}

TEST(Trainer, AlternatingTrainsResumesExactlyAndNeedsASelector) {
  const DemoDataset data(synthetic_demo_file(), DataConfig{});
  TrainConfig config = small_config();
  config.optimizer = "alternating";
  config.adam_eps = 1e-5;
  config.learning_rate = 3e-3;
  auto straight = small_maps(2);
  const Batch validation = data.validation_batch(ag::Dtype::Float32);
  const double untrained = mean_action_error(*straight, validation);
  const fs::path a = fresh_dir("alternating_straight"), b = fresh_dir("alternating_resumed");
  const TrainSummary full = train_policy(*straight, data, config, a.string(), nullptr);
  EXPECT_LT(full.best_validation_loss, untrained);
  TrainConfig partial = config;
  partial.steps = 40;
  auto first = small_maps(2);
  train_policy(*first, data, partial, b.string(), nullptr);
  auto second = small_maps(7);
  train_policy(*second, data, config, b.string(), nullptr);
  EXPECT_EQ(parameters_of(*straight), parameters_of(*second));

  ag::Generator gen(1);
  auto mt_bc = std::make_shared<MTBC>(PolicyShape{3, 2, 2}, gen, std::vector<std::int64_t>{8});
  EXPECT_THAT(error_of([&] { train_policy(*mt_bc, data, config, fresh_dir("alternating_mt_bc").string(), nullptr); }),
              HasSubstr("train.optimizer \"alternating\" steps the selector's parameters, then the others"));
  MAPSConfig uniform_config;
  uniform_config.modules = 3;
  uniform_config.module_hidden = {16};
  uniform_config.selector = "uniform";
  auto uniform = std::make_shared<MAPSPolicy>(PolicyShape{3, 2, 2}, uniform_config, gen);
  EXPECT_THAT(
      error_of([&] { train_policy(*uniform, data, config, fresh_dir("alternating_uniform").string(), nullptr); }),
      HasSubstr("trains no parameter named selector...; use \"joint\""));
}

TEST(RunConfig, SelectorKindsAreReadAndChecked) {
  nlohmann::json request = nlohmann::json::parse(R"({"method": "maps", "data": {"file": "x.h5"}})");
  EXPECT_EQ(parse_run_config(request).maps.selector, "learned");
  for (const std::string kind : {"uniform", "task"}) {
    request["maps"] = {{"selector", kind}};
    const RunConfig config = parse_run_config(request);
    EXPECT_EQ(config.maps.selector, kind);
    EXPECT_EQ(parse_run_config(to_json(config)).maps.selector, kind);
  }
  request["maps"] = {{"selector", "state"}};
  EXPECT_THAT(error_of([&] { parse_run_config(request); }),
              HasSubstr("config maps.selector: expected \"learned\", \"uniform\" or \"task\", got \"state\""));
}

TEST(RunConfig, OptimizerAndAdamEpsAreReadAndChecked) {
  nlohmann::json request = nlohmann::json::parse(R"({"method": "maps", "data": {"file": "x.h5"}})");
  EXPECT_EQ(parse_run_config(request).train.optimizer, "joint");
  EXPECT_EQ(parse_run_config(request).train.adam_eps, 1e-8);
  request["train"] = {{"optimizer", "alternating"}, {"adam_eps", 1e-5}};
  const RunConfig config = parse_run_config(request);
  EXPECT_EQ(config.train.optimizer, "alternating");
  EXPECT_EQ(config.train.adam_eps, 1e-5);
  EXPECT_EQ(to_json(config)["train"]["optimizer"], "alternating");
  request["train"] = {{"optimizer", "two_adams"}};
  EXPECT_THAT(error_of([&] { parse_run_config(request); }),
              HasSubstr("config train.optimizer: expected \"joint\" or \"alternating\", got \"two_adams\""));
  request["train"] = {{"adam_eps", 0}};
  EXPECT_THAT(error_of([&] { parse_run_config(request); }),
              HasSubstr("config train.adam_eps: expected a finite number in [1e-30, 1], got 0"));
  request["train"] = {{"adam_eps", 1e-40}};  // positive, but 0 in float32
  EXPECT_THAT(error_of([&] { parse_run_config(request); }),
              HasSubstr("config train.adam_eps: expected a finite number"));
}

TEST(RunConfig, ParsesDefaultsAndRejectsUnknownKeys) {
  const RunConfig c = parse_run_config(nlohmann::json::parse(
      R"({"method": "maml", "seed": 3, "data": {"file": "x.h5", "demos_per_task": 5, "subsample": 20},
          "maml": {"first_order": true}, "maps": {"selector_losses": {"share": 2, "smooth": 0}}})"));
  EXPECT_EQ(c.method, "maml");
  EXPECT_TRUE(c.maml.first_order);
  EXPECT_EQ(c.data.seed, 3u);
  EXPECT_EQ(c.train.steps, 30000);
  ASSERT_EQ(c.maps.selector_losses.size(), 2u);
  EXPECT_EQ(parse_run_config(to_json(c)).maml.query_per_task, 160);
  EXPECT_THAT(
      [] { parse_run_config(nlohmann::json::parse(R"({"method": "maps", "data": {"file": "x", "demo": 3}})")); },
      ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("unknown key 'demo'")));
  EXPECT_THAT([] { parse_run_config(nlohmann::json::parse(R"({"method": "gail", "data": {"file": "x"}})")); },
              ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("got \"gail\"")));
  EXPECT_THAT([] { parse_run_config(nlohmann::json::parse(R"({"method": "maps"})")); },
              ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("data")));
  for (const char* method : {"maps", "single_bc", "mt_bc", "mt_mh_bc", "maml"}) {
    RunConfig m = c;
    m.method = method;
    EXPECT_EQ(make_policy(m, {3, 2, 2})->shape().num_tasks, 2) << method;
  }
}

TEST(RunConfig, BaselineHiddenSizesReachEveryBaselineAndAreChecked) {
  RunConfig c = parse_run_config(
      nlohmann::json::parse(R"({"method": "mt_bc", "data": {"file": "x.h5"}, "baselines": {"hidden": [7, 5]}})"));
  EXPECT_EQ(c.baseline_hidden, (std::vector<std::int64_t>{7, 5}));
  EXPECT_EQ(parse_run_config(to_json(c)).baseline_hidden, c.baseline_hidden);
  // S = 3, A = 2, K = 2: the parameter count follows the hidden sizes.
  EXPECT_EQ(make_policy(c, {3, 2, 2})->parameter_count(), (3 + 2) * 7 + 7 + 7 * 5 + 5 + 5 * 2 + 2);
  for (const char* method : {"single_bc", "mt_mh_bc", "maml"}) {
    RunConfig m = c, wide = c;
    m.method = wide.method = method;
    wide.baseline_hidden = {70, 50};
    EXPECT_GT(make_policy(wide, {3, 2, 2})->parameter_count(), make_policy(m, {3, 2, 2})->parameter_count()) << method;
  }
  EXPECT_EQ(parse_run_config(nlohmann::json::parse(R"({"method": "mt_bc", "data": {"file": "x"}})")).baseline_hidden,
            (std::vector<std::int64_t>{128, 128, 128}));
  // Each bad "baselines" section, and the words its error must hold.
  const std::vector<std::pair<const char*, const char*>> bad = {
      {R"({"method": "mt_bc", "baselines": {"hidden": []}})", "baselines.hidden"},
      {R"({"method": "mt_bc", "baselines": {"hidden": [64, 0]}})", "baselines.hidden"},
      {R"({"method": "mt_bc", "baselines": {"width": 64}})", "unknown key 'width'"},
      {R"({"method": "mt_bc", "baselines": {"hidden": [64.5]}})", "64.5"},                    // not silently truncated
      {R"({"method": "maps", "baselines": {"hidden": [430]}})", "maps has no baseline MLP"},  // would do nothing
      {R"({"method": "moore", "baselines": {"hidden": [430]}})", "moore has no baseline MLP"},
  };
  for (const auto& [text, words] : bad) {
    nlohmann::json json = nlohmann::json::parse(text);
    json["data"] = {{"file", "x"}};
    EXPECT_THAT([&] { parse_run_config(json); }, ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr(words)))
        << text;
  }
  // A MAPS run's own resolved config (which lists the default) parses.
  RunConfig maps_run = c;
  maps_run.method = "maps";
  maps_run.baseline_hidden = detail::default_hidden_sizes();
  EXPECT_NO_THROW(parse_run_config(to_json(maps_run)));
}

// Found by fuzz/fuzz_run_config.cpp: a float where an integer belongs was truncated silently, and a size of 12E8
// reached the allocator (ASan: allocation-size-too-big) instead of an error naming the key.
TEST(RunConfig, IntegersMustBeIntegersAndModelsMustFitInMemory) {
  const auto with = [](const std::string& patch) {
    nlohmann::json j = nlohmann::json::parse(R"({"method": "maps", "data": {"file": "x.h5"}})");
    j.merge_patch(nlohmann::json::parse(patch));
    return j;
  };
  EXPECT_THAT(error_of([&] { parse_run_config(with(R"({"maps": {"modules": 2.5}})")); }),
              HasSubstr("config maps.modules: expected an integer in [1, 4096], got 2.5"));
  EXPECT_THAT(error_of([&] { parse_run_config(with(R"({"maps": {"module_hidden": [128, 12E8]}})")); }),
              HasSubstr("config maps.module_hidden[1]: expected an integer in [1, 65536], got 1200000000.0"));
  EXPECT_THAT(error_of([&] { parse_run_config(with(R"({"seed": -1})")); }),
              HasSubstr("config seed: expected an integer in [0, 18446744073709551615], got -1"));
  EXPECT_THAT(error_of([&] { parse_run_config(with(R"({"train": {"steps": 1e4}})")); }),
              HasSubstr("config train.steps: expected an integer in [1, 1000000000000], got 10000.0"));
  EXPECT_THAT(error_of([&] { parse_run_config(with(R"({"maps": {"modules": 0}})")); }),
              HasSubstr("config maps.modules: expected an integer in [1, 4096], got 0"));
  EXPECT_THAT(error_of([&] { parse_run_config(with(R"({"maps": {"selector_hidden": [4, -2]}})")); }),
              HasSubstr("config maps.selector_hidden[1]: expected an integer in [1, 65536], got -2"));
  // Each size within its key's range, the product far beyond memory.
  const RunConfig huge = parse_run_config(with(R"({"maps": {"modules": 4096, "module_hidden": [65536, 65536]}})"));
  EXPECT_THAT(error_of([&] {
                make_policy(huge, {39, 4, 10});
              }),
              HasSubstr("parameters, more than the 1e8 this library accepts; check maps.modules"));
  nlohmann::json wide = nlohmann::json::parse(R"({"method": "mt_bc", "data": {"file": "x.h5"},
                                                  "baselines": {"hidden": [65536, 65536, 65536]}})");
  EXPECT_THAT(error_of([&] { make_policy(parse_run_config(wide), {39, 4, 10}); }), HasSubstr("check baselines.hidden"));
}

// A run folder written before "baselines" existed resolves to the same config as today's request for the same run,
// so it resumes (experiments/run/train_run.cpp compares resolved configs).
TEST(RunConfig, SettingsThatWouldDoNothingOrFailLaterAreRefusedByName) {
  const auto with = [](const char* more) {
    nlohmann::json request = nlohmann::json::parse(R"({"method": "maps", "data": {"file": "x.h5"}})");
    request.merge_patch(nlohmann::json::parse(more));
    return request;
  };
  EXPECT_THAT(error_of([&] { parse_run_config(with(R"({"init": {"run": "r", "checkpoint": ".."}})")); }),
              HasSubstr("config init.checkpoint: expected a file name of the run folder"));
  EXPECT_THAT(error_of([&] { parse_run_config(with(R"({"init": {"run": "r", "checkpoint": "."}})")); }),
              HasSubstr("config init.checkpoint: expected a file name"));
  EXPECT_THAT(
      error_of([&] { parse_run_config(with(R"({"train": {"freeze": ["modules"], "lr_scale": {"modules0": 0.1}}})")); }),
      HasSubstr("config train.lr_scale.modules0: parameters under it are frozen (train.freeze \"modules\")"));
  // A prefix of which only a part is frozen still scales the rest (modules1, modules2 here).
  EXPECT_NO_THROW(parse_run_config(with(R"({"train": {"freeze": ["modules0"], "lr_scale": {"modules": 0.1}}})")));
  EXPECT_NO_THROW(parse_run_config(with(R"({"train": {"freeze": ["head"], "lr_scale": {"modules": 0.1}}})")));
  EXPECT_THAT(error_of([&] { parse_run_config(with(R"({"data": {"file": "x.h5", "task_demos": {"g/a": 0}}})")); }),
              HasSubstr("config data.task_demos.g/a: expected an integer in [1, 1000000], got 0"));
  EXPECT_THAT(error_of([&] {
                parse_run_config(with(R"({"data": {"file": "x.h5", "holdout": ["g/a"], "task_demos": {"g/a": 2}}})"));
              }),
              HasSubstr("config data.task_demos.g/a: the task is not trained (it is in data.holdout)"));
  EXPECT_THAT(error_of([&] {
                parse_run_config(with(R"({"data": {"file": "x.h5", "tasks": ["g/b"], "task_demos": {"g/a": 2}}})"));
              }),
              HasSubstr("config data.task_demos.g/a: the task is not trained (data.tasks leaves it out)"));
  // Type errors say what was expected.
  EXPECT_THAT(error_of([&] { parse_run_config(with(R"({"data": {"file": "x.h5", "holdout": "g/a"}})")); }),
              HasSubstr("config data.holdout: expected a list of strings, got \"g/a\""));
  EXPECT_THAT(error_of([&] { parse_run_config(with(R"({"train": {"optimizer": 5}})")); }),
              HasSubstr("config train.optimizer: expected \"joint\" or \"alternating\", got 5"));
  EXPECT_THAT(error_of([&] { parse_run_config(with(R"({"train": {"lr_scale": [1]}})")); }),
              HasSubstr("config train.lr_scale: expected an object of name: finite number in [0, 1000000], got [1]"));
}

TEST(RunConfig, DrawsAndValidationTasksAreReadAndChecked) {
  nlohmann::json request = nlohmann::json::parse(R"({"method": "maps", "data": {"file": "x.h5"}})");
  const RunConfig plain = parse_run_config(request);
  EXPECT_EQ(plain.data.draws, "sequential");
  EXPECT_TRUE(plain.train.validation_tasks.empty());
  request["data"]["draws"] = "per_task";
  request["train"]["validation_tasks"] = {"gravity/0.5"};
  const nlohmann::json written = to_json(parse_run_config(request));
  EXPECT_EQ(written["data"]["draws"], "per_task");
  EXPECT_EQ(written["train"]["validation_tasks"], nlohmann::json::array({"gravity/0.5"}));
  request["data"]["draws"] = "random";
  EXPECT_THAT(error_of([&] { parse_run_config(request); }),
              HasSubstr("data.draws: expected \"sequential\" or \"per_task\", got \"random\""));
}

TEST(RunConfig, TransferRequestTeachesOneTaskWithoutTheExploreTerm) {
  nlohmann::json source = to_json(parse_run_config(nlohmann::json::parse(
      R"({"method": "maps", "data": {"file": "x.h5", "demos_per_task": 10, "holdout": ["g/a"]},
          "train": {"validation_tasks": ["g/b"]}, "eval": {"tasks": ["g/b"]}})")));
  const nlohmann::json request = transfer_request(source, "g/a", 2, {"modules"}, 1.0);
  const RunConfig c = parse_run_config(request);
  EXPECT_EQ(c.data.tasks, std::vector<std::string>{"g/a"});
  EXPECT_TRUE(c.data.holdout.empty());
  EXPECT_EQ(c.data.task_demos, (std::vector<std::pair<std::string, int>>{{"g/a", 2}}));
  EXPECT_EQ(c.train.freeze, std::vector<std::string>{"modules"});
  EXPECT_TRUE(c.train.lr_scale.empty());
  EXPECT_TRUE(c.train.validation_tasks.empty());  // the new task is the run's only one
  EXPECT_TRUE(c.eval_tasks.empty());
  const auto source_losses = parse_run_config(source).maps.selector_losses;
  ASSERT_EQ(c.maps.selector_losses.size(), source_losses.size());
  for (std::size_t i = 0; i < source_losses.size(); ++i) {
    const auto& [name, weight] = c.maps.selector_losses[i];
    EXPECT_EQ(name, source_losses[i].first);
    EXPECT_EQ(weight, name == "explore" ? 0.0 : source_losses[i].second) << name;
  }
  const RunConfig tuned = parse_run_config(transfer_request(source, "g/a", 2, {}, 0.1));
  EXPECT_EQ(tuned.train.lr_scale, (std::vector<std::pair<std::string, double>>{{"modules", 0.1}}));
  source["init"]["run"] = "runs/started-from-another";
  EXPECT_THAT(error_of([&] { transfer_request(source, "g/a", 2, {"modules"}, 1.0); }),
              HasSubstr("the source started from another run (init.run runs/started-from-another)"));
}

TEST(RunConfig, AConfigWithoutANewerKeyResolvesAsItsDefault) {
  const nlohmann::json request = nlohmann::json::parse(
      R"({"method": "mt_bc", "seed": 2, "data": {"file": "x.h5", "demos_per_task": 5, "subsample": 10}})");
  nlohmann::json older = to_json(parse_run_config(request));
  older.erase("baselines");
  EXPECT_NE(older, to_json(parse_run_config(request)));
  EXPECT_EQ(to_json(parse_run_config(older)), to_json(parse_run_config(request)));
}

}  // namespace
}  // namespace maps::core
