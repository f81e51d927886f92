// `maps eval --last` reads the policy after the last training step from last.ckpt (load_final_policy): it must be
// the very policy the trainer keeps for that step (step_<N>.ckpt, best.ckpt when the last step was the best), with
// train.ema_power its average of the weights and without it the trained ones; a last.ckpt of another run, of an
// unfinished one, that is no training state or that disagrees with the config on the average is refused by name.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "envs/demo_file.h"
#include "experiments/run/run_folder.h"
#include "maps/training/trainer.h"
#include "nn/serialize.h"
#include "tests/common/error_of.h"
#include "tests/common/temp_folder.h"
#include "tests/maps/data/synthetic_demos.h"

namespace maps::experiments {
namespace {

using ::testing::HasSubstr;
using Json = nlohmann::json;

class FinalPolicy : public TempFolderTest {
 protected:
  FinalPolicy() : TempFolderTest("maps_final_policy_") {}

  void SetUp() override {
    TempFolderTest::SetUp();
    envs::DemoFile file = synthetic_demo_file();
    for (auto& demo : file.demos) {  // what a written file must hold besides the synthetic trajectories
      demo.final_obs = demo.obs.row(demo.obs.rows() - 1).transpose();
      demo.end = envs::EpisodeEnd::kTruncated;
    }
    envs::write_demo_file(path("demos.h5"), file);
  }

  // A trained MT-BC run folder as maps train leaves it (config.json, best.ckpt, last.ckpt, step_60.ckpt).
  std::string train(const std::string& name, double ema_power, std::int64_t steps = 60) {
    const Json json{{"method", "mt_bc"},
                    {"data", {{"file", path("demos.h5")}}},
                    {"baselines", {{"hidden", {8}}}},
                    {"train",
                     {{"steps", steps},
                      {"states_per_task", 16},
                      {"validate_every", 20},
                      {"checkpoint_every", 20},
                      {"keep_every", 60},
                      {"learning_rate", 1e-2},
                      {"ema_power", ema_power}}}};
    const core::RunConfig config = core::parse_run_config(json);
    const std::string run = path(name);
    std::filesystem::create_directories(run);
    write_json_file(run + "/config.json", core::to_json(config));
    const core::DemoDataset data(envs::read_demo_file(config.data_file), config.data);
    const auto policy = core::make_policy(config, {3, 2, 2});
    core::train_policy(*policy, data, config.train, run, nullptr);
    return run;
  }

  static std::vector<std::vector<double>> values(const nn::NamedTensors& tensors) {
    std::vector<std::vector<double>> out;
    for (const auto& t : tensors) out.push_back(t.tensor.to_vector());
    return out;
  }
  static std::vector<std::string> names(const nn::NamedTensors& tensors) {
    std::vector<std::string> out;
    for (const auto& t : tensors) out.push_back(t.name);
    return out;
  }
};

TEST_F(FinalPolicy, IsTheKeptCheckpointOfTheLastStepWithAndWithoutTheAverage) {
  for (const double ema_power : {0.75, 0.0}) {
    SCOPED_TRACE(ema_power);
    const std::string run = train(ema_power > 0 ? "averaged" : "trained", ema_power);
    const TrainedRun trained = load_trained_run(run);
    const auto final_policy = load_final_policy(run, trained);
    EXPECT_EQ(final_policy.step, 60);
    const nn::NamedTensors got = final_policy.policy->state_dict();
    const nn::NamedTensors kept = nn::load_tensors(run + "/step_60.ckpt").tensors;
    EXPECT_EQ(names(got), names(kept));
    EXPECT_EQ(values(got), values(kept));
    // The average is not the trained weights, so the equality above tells which one was read.
    const nn::NamedTensors raw = nn::strip_prefix(nn::load_tensors(run + "/last.ckpt").tensors, "policy.");
    if (ema_power > 0)
      EXPECT_NE(values(got), values(raw));
    else
      EXPECT_EQ(values(got), values(raw));
  }
}

TEST_F(FinalPolicy, ALastCheckpointThatIsNotThisFinishedRunsIsRefusedByName) {
  const std::string run = train("run", 0.75);
  const TrainedRun trained = load_trained_run(run);
  const std::string last = run + "/last.ckpt";
  const std::string saved = path("saved.ckpt");
  std::filesystem::copy_file(last, saved);

  // The config says no average; last.ckpt holds one.
  TrainedRun without = load_trained_run(run);
  without.config.train.ema_power = 0.0;
  EXPECT_THAT(error_of([&] { load_final_policy(run, without); }), HasSubstr("holds an average of the weights"));
  TrainedRun other_power = load_trained_run(run);
  other_power.config.train.ema_power = 0.5;
  EXPECT_THAT(error_of([&] { load_final_policy(run, other_power); }), HasSubstr("averages the weights with"));
  // A best.ckpt of another step than last.ckpt records as its best: not of one run.
  TrainedRun moved = load_trained_run(run);
  moved.best["step"] = moved.best["step"].get<std::int64_t>() == 20 ? 40 : 20;
  EXPECT_THAT(error_of([&] { load_final_policy(run, moved); }), HasSubstr("not of one run"));
  // An unfinished run: its last step short of train.steps.
  const std::string partial = train("partial", 0.75, 40);
  TrainedRun longer = load_trained_run(partial);
  longer.config.train.steps = 60;
  EXPECT_THAT(error_of([&] { load_final_policy(partial, longer); }), HasSubstr("at step 40 of 60"));
  // A policy checkpoint in last.ckpt's place, and none at all.
  std::filesystem::copy_file(run + "/best.ckpt", last, std::filesystem::copy_options::overwrite_existing);
  EXPECT_THAT(error_of([&] { load_final_policy(run, trained); }), HasSubstr("last.ckpt is not a training state"));
  std::filesystem::remove(last);
  EXPECT_THAT(error_of([&] { load_final_policy(run, trained); }), HasSubstr("has no last.ckpt"));
  // GAIL keeps its last iteration's policy as best.ckpt already.
  std::filesystem::copy_file(saved, last);
  TrainedRun gail = load_trained_run(run);
  gail.config.imitation = "gail";
  EXPECT_THAT(error_of([&] { load_final_policy(run, gail); }), HasSubstr("last iteration's policy already"));
  EXPECT_NO_THROW(load_final_policy(run, trained));
}

}  // namespace
}  // namespace maps::experiments
