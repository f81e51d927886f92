// Every key of the run config schema tried with the edge values of its type (issue 41): generated from the
// schema, so a key added later is covered without a new test.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include "io/config_schema.h"
#include "maps/training/run_config.h"
#include "maps/training/run_config_fields.h"
#include "tests/common/schema_trials.h"

namespace maps::core {
namespace {

using Json = nlohmann::json;
using io::Trial;
using io::trials_of;

// A config that holds `value` at `key` and is valid otherwise: the key's method is chosen for a method's section,
// and a method that uses baselines.hidden for that key.
Json config_with(const std::string& key, const Json& value) {
  Json config = {{"method", "maps"}, {"data", {{"file", "x.h5"}}}};
  const std::string section = key.substr(0, key.find('.'));
  for (const PolicyMethod& method : policy_methods())
    if (method.name == section) config["method"] = section;
  if (key == "baselines.hidden") config["method"] = "mt_bc";
  config[io::key_pointer(key)] = value;
  return config;
}

TEST(RunConfigSchema, EveryKeyTakesTheValuesOfItsRangeAndRefusesEveryOtherByName) {
  RunConfig parsed;
  const io::WalkCounts counts = io::walk_schema(
      run_config_schema(),
      [&parsed](const io::Field& field, const Json& value) {
        parsed = parse_run_config(config_with(field.key, value));
      },
      [](const io::Field& field, const Trial& trial, const std::string& error) {
        const std::string what = field.key + " = " + trial.value.dump();
        // A value the key's range allows may still be refused across keys (top_k above experts), by name.
        EXPECT_THAT(error, ::testing::HasSubstr(field.key)) << what;
        if (!trial.in_range) {
          EXPECT_THAT(error, ::testing::HasSubstr("expected")) << what;
        }
      },
      [&parsed](const io::Field& field, const Trial& trial) {
        // Accepted means kept as given: nothing wraps, rounds or is replaced.
        const Json written = to_json(parsed);
        const Json& kept = written.at(io::key_pointer(field.key));
        EXPECT_EQ(kept, trial.value) << field.key << " = " << trial.value.dump() << " became " << kept.dump();
      });
  EXPECT_GT(counts.tried, 1000);
  EXPECT_GT(counts.refused, counts.tried / 2);
}

TEST(RunConfigSchema, EveryDefaultIsInItsOwnRange) {
  for (const io::Field& field : run_config_schema()) {
    if (field.required) continue;
    EXPECT_NO_THROW(io::check_value(field, field.default_value)) << field.key;
  }
}

TEST(RunConfigSchema, TheDocsTableIsTheSchemasOwn) {
  std::ifstream in(std::string(MAPS_SOURCE_DIR) + "/docs/configs.md");
  std::stringstream text;
  text << in.rdbuf();
  EXPECT_NE(text.str().find(io::markdown_table(run_config_schema())), std::string::npos)
      << "docs/configs.md's table of keys is not `build/bin/maps schema run-config --markdown`'s output: paste it";
}

TEST(RunConfigSchema, ValuesAcceptedOnPurposeKeepTheirDocumentedMeaning) {
  // 0 is documented for these: all demos, every validation state, never keep, all cores, unadapted evaluation.
  for (const char* key : {"data.demos_per_task", "train.validation_states_per_task", "train.keep_every", "eval.threads",
                          "maml.finetune_steps", "maml.inner_lr"}) {
    EXPECT_NO_THROW(parse_run_config(config_with(key, 0))) << key;
    bool documented = false;
    for (const io::Field& field : run_config_schema())
      if (field.key == key) documented = field.meaning.find("0:") != std::string::npos;
    EXPECT_TRUE(documented) << key << ": 0 is accepted, so its meaning must say what 0 does";
  }
  // A weight of 0 is the ablation of that loss; a negative weight has no meaning.
  EXPECT_NO_THROW(parse_run_config(config_with("maps.selector_losses", {{"share", 0}})));
  EXPECT_THROW(parse_run_config(config_with("maps.selector_losses", {{"share", -1}})), std::invalid_argument);
}

// MAPS on raw inputs rebuilds them from the standardised ones: clamped ones would not be raw, so the pair is refused.
TEST(RunConfig, RawInputsAndAClampAreRefusedTogether) {
  Json config = config_with("data.observation_clip", 10);
  EXPECT_NO_THROW(parse_run_config(config));
  config["maps"]["observations"] = "raw_clipped";
  EXPECT_THAT([&] { parse_run_config(config); },
              ::testing::ThrowsMessage<std::invalid_argument>(::testing::HasSubstr(
                  "config data.observation_clip: maps.observations \"raw_clipped\" gives MAPS the raw observations")));
  config["data"]["observation_clip"] = 0;
  EXPECT_NO_THROW(parse_run_config(config));
}

// Under GAIL the trainer's own checks run when the config is read, so a config it would refuse never makes a run
// folder; a train key GAIL would ignore is refused by name; 0 validation states means every one, as under BC.
TEST(RunConfig, AGailConfigIsCheckedWhenItIsRead) {
  Json config = {{"method", "mt_bc"}, {"imitation", "gail"}, {"data", {{"file", "x.h5"}}}};
  config["train"]["validation_states_per_task"] = 0;
  EXPECT_EQ(gail_config_of(parse_run_config(config)).validation_states_per_task, 0);
  const auto refusal = [](const Json& bad) {
    try {
      parse_run_config(bad);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("(accepted)");
  };
  for (const char* key : {"critic_hidden", "discriminator_hidden"}) {
    Json deep = config;
    deep["gail"][key] = std::vector<int>(9, 16);
    EXPECT_THAT(refusal(deep),
                ::testing::HasSubstr(std::string("config gail.") + key + ": expected 1 to 8 layer sizes"));
  }
  Json subset = config;
  subset["train"]["validation_tasks"] = {"gravity/1.0"};
  EXPECT_THAT(refusal(subset), ::testing::HasSubstr("config train.validation_tasks: not available"));
  for (const char* key : {"minibatch_per_task", "discriminator_batch_per_task", "bc_states_per_task"}) {
    Json big = config;
    big["gail"][key] = 1000001;
    EXPECT_THAT(refusal(big), ::testing::HasSubstr(std::string("config gail.") + key + ": expected")) << key;
  }
}

}  // namespace
}  // namespace maps::core
