// Methods predicting action chunks (issue 46): chunking.* widens any one-action method's output to H actions and
// records how they are executed; Diffusion Policy as a registered method: its section and refusals, its parameter
// count as the registry estimates it and matched to MAPS's, deterministic sampling that does not depend on the batch,
// a validation loss drawn the same at every call, and a small two-task problem it learns to sample.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <string>
#include <vector>

#include "maps/policies/diffusion_policy.h"
#include "maps/policies/policy_registry.h"
#include "maps/training/run_config.h"
#include "nn/optim/adam.h"
#include "tests/common/error_of.h"
#include "tests/maps/data/synthetic_demos.h"
#include "tests/maps/policies/baseline_test_util.h"

namespace {

namespace ag = maps::ag;
namespace core = maps::core;
using ::testing::HasSubstr;

core::RunConfig config_of(const nlohmann::json& extra) {
  nlohmann::json json{{"data", {{"file", "unused.h5"}}}};
  json.update(extra);
  return core::parse_run_config(json);
}

// A batch of two tasks whose chunks [H, 2] are a fixed pattern per task (task 0 rising, task 1 falling), the states
// random: what a diffusion policy must learn to sample.
core::Batch chunk_batch(std::int64_t horizon, std::int64_t per_task, std::uint64_t seed) {
  ag::Generator gen(seed);
  core::Batch b;
  const std::int64_t n = 2 * per_task;
  b.observations = ag::rand({n, 3}, gen, ag::Dtype::Float64, -1.0, 1.0);
  b.previous_observations = b.observations;
  std::vector<double> actions;
  for (std::int64_t r = 0; r < n; ++r) {
    b.tasks.push_back(r / per_task);
    for (std::int64_t j = 0; j < horizon; ++j) {
      const double u = static_cast<double>(j) / static_cast<double>(horizon - 1);
      actions.push_back(r < per_task ? -0.6 + 1.2 * u : 0.6 - 1.2 * u);
      actions.push_back(r < per_task ? 0.5 : -0.5);
    }
  }
  b.actions = ag::from_vector(actions, {n, horizon * 2}, ag::Dtype::Float64);
  b.per_task = per_task;
  return b;
}

TEST(ActionChunking, ChunkingWidensAOneActionMethodsOutputAndRecordsTheExecution) {
  const core::RunConfig config =
      config_of({{"method", "mt_bc"}, {"chunking", {{"horizon", 4}, {"execution", "open_loop"}, {"execute", 2}}}});
  EXPECT_EQ(config.data.action_horizon, 4);
  const core::PolicyShape shape{3, 2, 4};
  const auto policy = core::make_policy(config, shape);
  EXPECT_EQ(policy->shape().action_size, 8);
  EXPECT_EQ(policy->step_action_size(), 2);
  EXPECT_EQ(policy->chunking().horizon, 4);
  EXPECT_EQ(policy->chunking().execution, "open_loop");
  EXPECT_EQ(policy->chunking().execute, 2);
  const core::Batch batch = baselinetest::make_batch(4, 5, 1);
  EXPECT_EQ(policy->act(batch.observations, batch.tasks).shape(), (ag::Shape{20, 8}));
  EXPECT_EQ(static_cast<double>(policy->parameter_count()), core::policy_parameter_count(config, shape));
  // Its loss is the BC loss on the whole chunk: a chunked batch trains it.
  core::Batch chunked = batch;
  chunked.actions = ag::concat({batch.actions, batch.actions, batch.actions, batch.actions}, 1);
  const auto losses = baselinetest::train(*policy, chunked, 300, 3e-3);
  EXPECT_LT(losses.back(), 0.1 * losses.front());
  // The default is one action per step, as before chunking existed.
  const auto plain = core::make_policy(config_of({{"method", "mt_bc"}}), shape);
  EXPECT_EQ(plain->shape().action_size, 2);
  EXPECT_FALSE(plain->chunking().chunked());
}

TEST(ActionChunking, RefusalsNameTheKey) {
  EXPECT_THAT(error_of([] {
                config_of({{"method", "maps"}, {"chunking", {{"horizon", 0}}}});
              }),
              HasSubstr("chunking.horizon"));
  EXPECT_THAT(
      error_of([] {
        config_of({{"method", "maps"}, {"chunking", {{"horizon", 3}, {"execution", "open_loop"}, {"execute", 4}}}});
      }),
      HasSubstr("config chunking.execute: expected 1 to the horizon (3)"));
  EXPECT_THAT(error_of([] {
                config_of({{"method", "maps"}, {"chunking", {{"execution", "closed"}}}});
              }),
              HasSubstr("chunking.execution"));
  EXPECT_THAT(error_of([] {
                config_of({{"method", "diffusion_policy"}, {"chunking", {{"horizon", 4}}}});
              }),
              HasSubstr("config chunking: diffusion_policy predicts chunks of its own"));
  EXPECT_THAT(error_of([] {
                config_of({{"method", "mt_bc"}, {"imitation", "gail"}, {"chunking", {{"horizon", 4}}}});
              }),
              HasSubstr("GAIL's PPO acts one step at a time"));
}

TEST(ImitationObjective, GailRefusesTheMethodsItCannotTrainSayingWhyBeforeAnythingElse) {
  // Diffusion Policy at one action a chunk passes every chunk check, so only the method's own refusal stops it.
  for (const nlohmann::json& section :
       {nlohmann::json::object(), nlohmann::json{{"denoiser", "mlp"}, {"horizon", 1}, {"execute", 1}}})
    EXPECT_THAT(error_of([&] {
                  config_of({{"method", "diffusion_policy"}, {"imitation", "gail"}, {"diffusion_policy", section}});
                }),
                HasSubstr("config imitation: \"gail\" trains a Gaussian policy by PPO; diffusion_policy: it samples "
                          "its actions by denoising"));
  EXPECT_THAT(error_of([] {
                config_of({{"method", "maml"}, {"imitation", "gail"}});
              }),
              HasSubstr("maml: its adaptation is a BC inner loop (use imitation \"bc\" for maml)"));
  for (const char* method : {"maps", "single_bc", "mt_bc", "mt_mh_bc", "moore", "soft_modularization"})
    EXPECT_EQ(config_of({{"method", method}, {"imitation", "gail"}}).imitation, "gail") << method;
}

TEST(DiffusionPolicy, ItsSectionSetsItsChunksAndItsRefusalsNameTheKey) {
  const core::RunConfig config = config_of({{"method", "diffusion_policy"}});
  const auto chunks = core::action_chunking(config);
  EXPECT_EQ(chunks.horizon, 16);
  EXPECT_EQ(chunks.execution, "open_loop");
  EXPECT_EQ(chunks.execute, 8);
  EXPECT_TRUE(chunks.previous_observation);
  EXPECT_EQ(config.data.action_horizon, 16);
  const auto one =
      core::action_chunking(config_of({{"method", "diffusion_policy"}, {"diffusion_policy", {{"observations", 1}}}}));
  EXPECT_FALSE(one.previous_observation);
  const auto refused = [](const nlohmann::json& own) {
    return error_of([&] { config_of({{"method", "diffusion_policy"}, {"diffusion_policy", own}}); });
  };
  EXPECT_THAT(refused({{"horizon", 6}, {"execute", 3}}),
              HasSubstr("config diffusion_policy.horizon: the U-Net halves the chunk twice"));
  EXPECT_THAT(refused({{"width", 12}}), HasSubstr("config diffusion_policy.width: the U-Net's group norms take 8"));
  EXPECT_THAT(refused({{"execute", 17}}), HasSubstr("config diffusion_policy.execute: expected at most"));
  EXPECT_THAT(refused({{"inference_steps", 20}, {"training_steps", 10}}),
              HasSubstr("config diffusion_policy.inference_steps: expected at most"));
  EXPECT_THAT(refused({{"denoiser", "transformer"}}), HasSubstr("diffusion_policy.denoiser"));
  // The MLP takes any horizon and width.
  EXPECT_NO_THROW(
      config_of({{"method", "diffusion_policy"},
                 {"diffusion_policy", {{"denoiser", "mlp"}, {"horizon", 6}, {"execute", 3}, {"width", 12}}}}));
}

TEST(DiffusionPolicy, ParameterCountIsTheRegistrysEstimateAndTheDefaultIsMatchedToMAPS) {
  const core::PolicyShape step_shape{17, 6, 5};
  for (const nlohmann::json& own :
       {nlohmann::json{{"width", 16}}, nlohmann::json{{"width", 24}, {"observations", 1}, {"horizon", 8}},
        nlohmann::json{{"denoiser", "mlp"}, {"width", 40}, {"layers", 2}, {"horizon", 5}, {"execute", 5}},
        nlohmann::json{{"denoiser", "maps"}, {"width", 20}, {"horizon", 6}, {"execute", 3}},
        nlohmann::json{{"denoiser", "moe"}, {"width", 20}, {"experts", 3}, {"top_k", 2}, {"layers", 2}}}) {
    const auto config = config_of({{"method", "diffusion_policy"}, {"diffusion_policy", own}});
    const auto policy = core::make_policy(config, step_shape);
    EXPECT_EQ(static_cast<double>(policy->parameter_count()), core::policy_parameter_count(config, step_shape))
        << own.dump();
  }
  // Width 0: the multiple of 8 (U-Net) or the width (MLP, MAPS, MoE) whose count is nearest MAPS's at one action per
  // step.
  for (const std::string denoiser : {"unet", "mlp", "maps", "moe"}) {
    const auto config = config_of({{"method", "diffusion_policy"}, {"diffusion_policy", {{"denoiser", denoiser}}}});
    const double maps_count = core::maps_parameter_count(config_of({{"method", "maps"}}), step_shape);
    const auto policy = core::make_policy(config, step_shape);
    const auto& chosen = dynamic_cast<const core::DiffusionPolicy&>(*policy).config();
    const std::int64_t unit = denoiser == "unet" ? 8 : 1;
    const double count = static_cast<double>(policy->parameter_count());
    for (const std::int64_t other : {chosen.width - unit, chosen.width + unit}) {
      auto sized =
          config_of({{"method", "diffusion_policy"}, {"diffusion_policy", {{"denoiser", denoiser}, {"width", other}}}});
      EXPECT_LE(std::abs(count - maps_count), std::abs(core::policy_parameter_count(sized, step_shape) - maps_count))
          << denoiser << " width " << chosen.width << " against " << other;
    }
  }
}

TEST(DiffusionPolicy, SamplingIsDeterministicAndDoesNotDependOnTheBatch) {
  const auto config = config_of(
      {{"method", "diffusion_policy"}, {"diffusion_policy", {{"width", 16}, {"horizon", 4}, {"execute", 2}}}});
  const auto policy = core::make_policy(config, {3, 2, 2});
  policy->to(ag::Dtype::Float64);
  const core::Batch batch = chunk_batch(4, 3, 2);
  const ag::Tensor all = policy->act_with_history(batch.observations, batch.previous_observations, batch.tasks);
  ASSERT_EQ(all.shape(), (ag::Shape{6, 8}));
  EXPECT_EQ(all.to_vector(),
            policy->act_with_history(batch.observations, batch.previous_observations, batch.tasks).to_vector());
  for (std::int64_t r = 0; r < 6; ++r) {
    const core::Batch row = baselinetest::rows_of(batch, {r});
    const ag::Tensor alone = policy->act_with_history(row.observations, row.previous_observations, row.tasks);
    EXPECT_LT(max_abs_diff(alone, ag::narrow(all, 0, r, 1)), 1e-9) << "row " << r;
  }
  // Sampled chunks stay in the action box (clip).
  for (double v : all.to_vector()) EXPECT_LE(std::abs(v), 1.0 + 1e-12);
  // The validation loss draws the same steps and noise at every call.
  const core::DemoDataset data(synthetic_demo_file(), core::DataConfig{});  // not read by this method
  const double first = policy->validation_loss(batch, data);
  EXPECT_TRUE(std::isfinite(first));
  EXPECT_EQ(first, policy->validation_loss(batch, data));
}

// The "maps" denoiser: MAPS's weighting of the denoising loss and its selector losses, its routing as the policy's.
TEST(DiffusionPolicy, TheMAPSDenoiserAddsMAPSsSelectorLossesAndRoutes) {
  const auto config =
      config_of({{"method", "diffusion_policy"},
                 {"maps", {{"modules", 3}, {"selector_hidden", {8}}}},
                 {"diffusion_policy", {{"denoiser", "maps"}, {"width", 12}, {"horizon", 4}, {"execute", 2}}}});
  const auto policy = core::make_policy(config, {3, 2, 2});
  policy->to(ag::Dtype::Float64);
  ASSERT_EQ(policy->routed_modules(), 3);
  core::Batch batch = chunk_batch(4, 5, 6);
  batch.previous_observations = batch.observations * 0.9;
  const core::LossTerms terms = policy->loss(batch);
  std::vector<std::string> names;
  for (const auto& [name, value] : terms.terms) names.push_back(name);
  EXPECT_EQ(names, (std::vector<std::string>{"denoise", "share", "explore", "sparse", "smooth"}));
  const std::vector<double> lambdas{1.0, 0.5, 0.001, 1.0};
  double expected = 0.75 * terms.terms[0].second.item();
  for (std::size_t j = 0; j < 4; ++j) expected += 0.25 * lambdas[j] * terms.terms[j + 1].second.item();
  EXPECT_NEAR(terms.total.item(), expected, 1e-12);
  const ag::Tensor routing = policy->routing(batch.observations, batch.tasks);
  ASSERT_EQ(routing.shape(), (ag::Shape{10, 3}));
  const auto values = routing.to_vector();
  for (std::int64_t r = 0; r < 10; ++r) EXPECT_NEAR(values[3 * r] + values[3 * r + 1] + values[3 * r + 2], 1.0, 1e-12);
  // The other denoisers do not route.
  const auto plain = core::make_policy(
      config_of({{"method", "diffusion_policy"}, {"diffusion_policy", {{"denoiser", "mlp"}, {"width", 12}}}}),
      {3, 2, 2});
  EXPECT_EQ(plain->routed_modules(), 0);
  EXPECT_FALSE(plain->routing(batch.observations.to(ag::Dtype::Float32), batch.tasks).defined());
  EXPECT_THAT(error_of([] {
                core::make_policy(config_of({{"method", "diffusion_policy"},
                                             {"maps", {{"selector", "uniform"}}},
                                             {"diffusion_policy", {{"denoiser", "maps"}}}}),
                                  {3, 2, 2});
              }),
              HasSubstr("config maps.selector: the \"maps\" denoiser has a learned selector"));
}

// MAPS's denoiser and the top-k MoE too (issue 46, item 3), with their routing losses at their weights.
// The "moe" denoiser: the denoising loss less the weighted mutual information; routing the kept gates scaled to 1.
TEST(DiffusionPolicy, TheMoEDenoiserRewardsTaskExpertInformationAndRoutesTopK) {
  const auto config =
      config_of({{"method", "diffusion_policy"},
                 {"diffusion_policy",
                  {{"denoiser", "moe"}, {"width", 12}, {"horizon", 4}, {"execute", 2}, {"experts", 3}, {"top_k", 2}}}});
  const auto policy = core::make_policy(config, {3, 2, 2});
  policy->to(ag::Dtype::Float64);
  ASSERT_EQ(policy->routed_modules(), 3);
  const core::Batch batch = chunk_batch(4, 5, 7);
  const core::LossTerms terms = policy->loss(batch);
  ASSERT_EQ(terms.terms.size(), 2u);
  EXPECT_EQ(terms.terms[1].first, "mutual_information");
  EXPECT_NEAR(terms.total.item(), terms.terms[0].second.item() - 5e-4 * terms.terms[1].second.item(), 1e-12);
  const auto values = policy->routing(batch.observations, batch.tasks).to_vector();
  ASSERT_EQ(values.size(), 30u);
  for (std::size_t r = 0; r < 10; ++r) {
    int kept = 0;
    for (std::size_t e = 0; e < 3; ++e) kept += values[3 * r + e] > 0.0;
    EXPECT_EQ(kept, 2) << "row " << r;
    EXPECT_NEAR(values[3 * r] + values[3 * r + 1] + values[3 * r + 2], 1.0, 1e-12);
  }
  EXPECT_THAT(error_of([] {
                config_of({{"method", "diffusion_policy"}, {"diffusion_policy", {{"experts", 2}, {"top_k", 3}}}});
              }),
              HasSubstr("config diffusion_policy.top_k: expected at most diffusion_policy.experts (2), got 3"));
}

TEST(DiffusionPolicy, LearnsToSampleEachTasksChunk) {
  if (std::getenv("MAPS_TEST_QUICK")) GTEST_SKIP() << "a learning check, run in the Release pass";
  for (const std::string denoiser : {"mlp", "maps", "moe"}) {
    const auto config = config_of({{"method", "diffusion_policy"},
                                   {"seed", 3},
                                   {"maps", {{"modules", 3}, {"selector_hidden", {16}}}},
                                   {"diffusion_policy",
                                    {{"denoiser", denoiser},
                                     {"width", denoiser == "maps" ? 32 : 64},
                                     {"experts", 4},
                                     {"horizon", 4},
                                     {"execute", 2},
                                     {"training_steps", 50},
                                     {"inference_steps", 10}}}});
    const auto policy = core::make_policy(config, {3, 2, 2});
    core::Batch batch = chunk_batch(4, 32, 4);
    batch.observations = batch.observations.to(ag::Dtype::Float32);
    batch.previous_observations = batch.observations;
    batch.actions = batch.actions.to(ag::Dtype::Float32);
    maps::optim::Adam adam(policy->parameters(), {.lr = 2e-3});
    for (int step = 0; step < 1500; ++step) {
      batch.noise_seed = static_cast<std::uint64_t>(step);
      adam.zero_grad();
      policy->loss(batch).total.backward();
      adam.step();
    }
    const core::Batch fresh = chunk_batch(4, 8, 5);
    const ag::Tensor sampled = policy->act(fresh.observations.to(ag::Dtype::Float32), fresh.tasks);
    const double error = max_abs_diff(sampled.to(ag::Dtype::Float64), fresh.actions);
    EXPECT_LT(error, 0.15) << denoiser << ": largest error of a sampled action";
  }
}

}  // namespace
