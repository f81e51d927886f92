// Checkpoints damaged at random (issue 41, item 6): the binary container (a checksum over every byte) and the JSON
// records of best.ckpt and last.ckpt, rewritten with a valid checksum so that only the record's own checks stand.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "maps/training/checkpoint_record.h"
#include "maps/training/run_config.h"
#include "nn/serialize.h"
#include "tests/common/mutations.h"
#include "tests/common/schema_trials.h"
#include "tests/common/temp_folder.h"

namespace maps::core {
namespace {

using Json = nlohmann::json;

class CheckpointProperty : public TempFolderTest {
 protected:
  CheckpointProperty() : TempFolderTest("maps_checkpoint_property_") {}

  void SetUp() override {
    TempFolderTest::SetUp();
    const RunConfig config =
        parse_run_config({{"method", "mt_bc"}, {"data", {{"file", "x.h5"}}}, {"baselines", {{"hidden", {8}}}}});
    policy_ = make_policy(config, {4, 3, 2});
    record_.step = 120;
    record_.validation_bc = 0.25;
    record_.standardizer.mean = Eigen::VectorXd::LinSpaced(4, -1.0, 1.0);
    record_.standardizer.std = Eigen::VectorXd::Constant(4, 0.5);
    record_.standardizer.clip = 10.0;  // mutants drop or change it
  }

  // What a policy checkpoint's reader does: the container, the record against 4 observations, the tensors.
  void read_policy(const std::string& path) const {
    const nn::Checkpoint saved = nn::load_tensors(path);
    read_policy_record(saved.config, "checkpoint " + path, 4);
    policy_->clone()->load_state_dict(saved.tensors);
  }

  std::shared_ptr<Policy> policy_;
  PolicyRecord record_;
};

TEST_F(CheckpointProperty, EveryDamagedByteIsRefusedByTheChecksum) {
  const std::string path = this->path("best.ckpt");
  nn::save(*policy_, path, to_json(record_).dump());
  const std::string original = testing::read_bytes(path);
  const auto counts = testing::check_mutants(
      "checkpoint bytes", original, path, testing::property_cases(300),
      [&](std::mt19937_64& rng, std::string& how) { return testing::byte_mutant(original, rng, how); },
      [&](const std::string& p) { read_policy(p); },
      [](std::string& why) {
        why = "a checkpoint whose bytes changed passed the checksum";
        return false;
      });
  EXPECT_EQ(counts.accepted, 0);
}

// The record's invariants, checked here apart from the reader: what an accepted record must satisfy.
bool policy_record_holds(const Json& r, std::string& why) {
  auto fail = [&why](const std::string& what) {
    why = what;
    return false;
  };
  if (!r.is_object()) return fail("not an object");
  for (const auto& [key, value] : r.items())
    if (key != "format" && key != "step" && key != "validation_bc" && key != "standardizer")
      return fail("unknown key " + key);
  if (r.contains("format") && r["format"] != "maps-policy 1") return fail("format " + r["format"].dump());
  if (!r.contains("step") || !r["step"].is_number_integer() || r["step"].get<std::int64_t>() < 0)
    return fail("step " + r.value("step", Json()).dump());
  if (r.contains("validation_bc") && (!r["validation_bc"].is_number() || !(r["validation_bc"].get<double>() >= 0.0) ||
                                      !std::isfinite(r["validation_bc"].get<double>())))
    return fail("validation_bc " + r["validation_bc"].dump());
  const Json s = r.value("standardizer", Json());
  if (!s.is_object() || s.size() != (s.contains("clip") ? 3u : 2u) || !s.contains("mean") || !s.contains("std"))
    return fail("standardizer");
  if (s.contains("clip") &&
      (!s["clip"].is_number() || !(s["clip"].get<double>() >= 0.0 && s["clip"].get<double>() <= 1e6)))
    return fail("standardizer.clip " + s["clip"].dump());
  if (!s["mean"].is_array() || !s["std"].is_array() || s["mean"].size() != 4 || s["std"].size() != 4)
    return fail("standardizer lengths");
  for (std::size_t i = 0; i < 4; ++i)
    if (!s["mean"][i].is_number() || !s["std"][i].is_number() || !(s["std"][i].get<double>() >= 1e-6) ||
        !std::isfinite(s["mean"][i].get<double>()) || !std::isfinite(s["std"][i].get<double>()))
      return fail("standardizer entry " + std::to_string(i));
  return true;
}

TEST_F(CheckpointProperty, ARecordIsAcceptedOnlyWhenEveryKeyIsInRange) {
  const std::string path = this->path("best.ckpt");
  const Json original = to_json(record_);
  Json mutated;
  testing::check_mutants(
      "policy record", "", path, testing::property_cases(400),
      [&](std::mt19937_64& rng, std::string& how) {
        mutated = testing::json_mutant(original, rng, how);
        nn::save(*policy_, path, mutated.dump());
        return testing::read_bytes(path);
      },
      [&](const std::string& p) { read_policy(p); },
      [&](std::string& why) { return policy_record_holds(mutated, why); });
}

bool training_state_holds(const Json& r, std::string& why) {
  auto fail = [&why](const std::string& what) {
    why = what;
    return false;
  };
  if (!r.is_object()) return fail("not an object");
  for (const auto& [key, value] : r.items()) {
    if (key == "ema_power" || key == "ema_max_decay") {
      const double top = key == "ema_power" ? 10.0 : 0.999999;
      if (!value.is_number() || !(value.get<double>() >= 0.0 && value.get<double>() <= top)) return fail(key);
    } else if (key != "format" && key != "step" && key != "best_step" && key != "best_validation" && key != "rng") {
      return fail("unknown key " + key);
    }
  }
  for (const char* key : {"format", "step", "best_step", "best_validation", "rng"})
    if (!r.contains(key)) return fail(std::string("no ") + key);
  if (r.value("format", Json()) != "maps-train 1") return fail("format");
  const Json step = r.value("step", Json()), best = r.value("best_step", Json());
  if (!step.is_number_integer() || step.get<std::int64_t>() < 0) return fail("step " + step.dump());
  if (!best.is_number_integer() || best.get<std::int64_t>() < -1 || best.get<std::int64_t>() > step.get<std::int64_t>())
    return fail("best_step " + best.dump());
  const Json valid = r.value("best_validation", Json(0));
  if (!valid.is_null() && (!valid.is_number() || !(valid.get<double>() >= 0.0) || !std::isfinite(valid.get<double>())))
    return fail("best_validation " + valid.dump());
  if (!r.value("rng", Json()).is_string() || r["rng"].get<std::string>().empty()) return fail("rng");
  return true;
}

TEST_F(CheckpointProperty, ATrainingStateIsAcceptedOnlyWhenEveryKeyIsInRange) {
  const std::string path = this->path("last.ckpt");
  TrainingState state;
  state.step = 300;
  state.best_step = 200;
  state.best_validation = 0.5;
  state.rng = "5489 1 2 3";
  state.ema_power = 0.75;  // a run keeping an average records it; mutants drop or change it
  state.ema_max_decay = 0.9999;
  const Json original = to_json(state);
  Json mutated;
  testing::check_mutants(
      "training state", "", path, testing::property_cases(400),
      [&](std::mt19937_64& rng, std::string& how) {
        mutated = testing::json_mutant(original, rng, how);
        nn::save_tensors(path, {}, mutated.dump());
        return testing::read_bytes(path);
      },
      [&](const std::string& p) { read_training_state(nn::load_tensors(p).config, "training checkpoint " + p); },
      [&](std::string& why) { return training_state_holds(mutated, why); });
}

}  // namespace
}  // namespace maps::core

namespace maps::core {
namespace {

// The clamp survives a round trip, and a record without it (every run before data.observation_clip) reads as none.
TEST(CheckpointRecord, TheObservationClipRoundTripsAndIsAbsentWhenNone) {
  PolicyRecord policy;
  policy.step = 5;
  policy.standardizer.mean = Eigen::VectorXd::Zero(2);
  policy.standardizer.std = Eigen::VectorXd::Ones(2);
  EXPECT_FALSE(to_json(policy)["standardizer"].contains("clip"));
  EXPECT_EQ(read_policy_record(to_json(policy).dump(), "best.ckpt", 2).standardizer.clip, 0.0);
  policy.standardizer.clip = 10.0;
  EXPECT_EQ(read_policy_record(to_json(policy).dump(), "best.ckpt", 2).standardizer.clip, 10.0);
  Json negative = to_json(policy);
  negative["standardizer"]["clip"] = -1.0;
  EXPECT_THAT([&] { read_policy_record(negative.dump(), "best.ckpt", 2); },
              ::testing::ThrowsMessage<std::runtime_error>(::testing::HasSubstr("standardizer.clip")));
  Json unknown = to_json(policy);
  unknown["standardizer"]["bound"] = 1.0;
  EXPECT_THAT([&] { read_policy_record(unknown.dump(), "best.ckpt", 2); },
              ::testing::ThrowsMessage<std::runtime_error>(::testing::HasSubstr("unknown key 'standardizer.bound'")));
}

// Every key of each record's table tried with the edge values of its type, as the run config's are.
TEST(CheckpointRecordSchema, EveryKeyTakesTheValuesOfItsRangeAndRefusesEveryOtherByName) {
  PolicyRecord policy;
  policy.step = 5;
  policy.validation_bc = 0.5;
  policy.standardizer.mean = Eigen::VectorXd::Zero(2);
  policy.standardizer.std = Eigen::VectorXd::Ones(2);
  TrainingState state;
  state.step = 5;
  state.best_step = 5;
  state.rng = "1 2 3";
  state.ema_power = 0.75;
  state.ema_max_decay = 0.9999;
  for (const bool training : {false, true}) {
    const Json base = training ? to_json(state) : to_json(policy);
    const auto counts = io::walk_schema<std::runtime_error>(
        training ? training_state_schema() : policy_record_schema(),
        [&](const io::Field& field, const Json& value) {
          Json record = base;
          record[io::key_pointer(field.key)] = value;
          if (training) {
            read_training_state(record.dump(), "last.ckpt");
          } else {
            read_policy_record(record.dump(), "best.ckpt", -1);
          }
        },
        [&](const io::Field& field, const io::Trial& trial, const std::string& error) {
          EXPECT_NE(error.find(training ? "last.ckpt" : "best.ckpt"), std::string::npos) << error;
          // In range but refused: a list of other length than its twin (mean and std), best_step past step.
          if (!trial.in_range) {
            EXPECT_NE(error.find(field.key), std::string::npos) << error;
          }
        },
        [](const io::Field&, const io::Trial&) {}, /*through_text=*/true);
    EXPECT_GT(counts.refused, 0);
  }
}

}  // namespace
}  // namespace maps::core
