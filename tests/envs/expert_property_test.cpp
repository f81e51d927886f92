// Expert files damaged at random (issue 41, item 6): bytes and JSON structure of a committed expert changed. The
// loader must refuse them naming the file, or read a policy whose every invariant holds (checked here apart from
// the loader); a changed weight is another valid policy, which no format without a checksum can tell.
#include <gtest/gtest.h>

#include <string>

#include "envs/expert_policy.h"
#include "envs/source_folders.h"
#include "tests/common/mutations.h"
#include "tests/common/schema_trials.h"
#include "tests/common/temp_folder.h"

namespace maps::envs {
namespace {

class ExpertProperty : public TempFolderTest {
 protected:
  ExpertProperty() : TempFolderTest("maps_expert_property_") {}
};

bool invariants_hold(const ExpertPolicy& p, std::string& why) {
  auto fail = [&why](const std::string& what) {
    why = what;
    return false;
  };
  if (p.weights.empty() || p.weights.size() != p.biases.size()) return fail("layers");
  for (std::size_t i = 0; i < p.weights.size(); ++i) {
    if (p.biases[i].size() != p.weights[i].rows() || (i > 0 && p.weights[i].cols() != p.weights[i - 1].rows()))
      return fail("layer shapes");
    if (!p.weights[i].allFinite() || !p.biases[i].allFinite()) return fail("a non-finite weight");
  }
  if (p.obs_mean.size() != p.weights[0].cols() || p.obs_var.size() != p.weights[0].cols()) return fail("obs sizes");
  if (!((p.obs_var.array() >= 0.0).all()) || !(p.obs_clip > 0.0) || !(p.obs_epsilon >= 0.0)) return fail("ranges");
  if (p.log_std.size() != p.weights.back().rows() || !p.log_std.allFinite()) return fail("log_std");
  return true;
}

TEST_F(ExpertProperty, ADamagedExpertIsRefusedOrReadWithEveryInvariantIntact) {
  const std::string committed =
      (find_source_folder("envs/experts", "MAPS_EXPERTS_DIR") / "gravity" / "1.0.json").string();
  const std::string original = testing::read_bytes(committed);
  ASSERT_FALSE(original.empty()) << committed;
  const nlohmann::json document = nlohmann::json::parse(original);
  ExpertPolicy read;
  auto load = [&](const std::string& p) { read = ExpertPolicy::load(p); };
  auto holds = [&](std::string& why) { return invariants_hold(read, why); };
  const auto bytes = testing::check_mutants(
      "expert file bytes", original, path("expert.json"), testing::property_cases(150),
      [&](std::mt19937_64& rng, std::string& how) { return testing::byte_mutant(original, rng, how); }, load, holds);
  EXPECT_GT(bytes.refused, 0);
  const auto structure = testing::check_mutants(
      "expert file structure", original, path("expert.json"), testing::property_cases(150),
      [&](std::mt19937_64& rng, std::string& how) { return testing::json_mutant(document, rng, how).dump(1); }, load,
      holds);
  EXPECT_GT(structure.refused, 0);
}

}  // namespace
}  // namespace maps::envs

namespace maps::envs {
namespace {

// Every key of the expert file's table tried with the edge values of its type, as the run config's are.
TEST_F(ExpertProperty, EveryKeyTakesTheValuesOfItsRangeAndRefusesEveryOtherByName) {
  const std::string committed =
      (find_source_folder("envs/experts", "MAPS_EXPERTS_DIR") / "gravity" / "1.0.json").string();
  const nlohmann::json document = nlohmann::json::parse(testing::read_bytes(committed));
  const std::string file = path("expert.json");
  const auto counts = io::walk_schema<std::runtime_error>(
      expert_file_schema(),
      [&](const io::Field& field, const nlohmann::json& value) {
        nlohmann::json edited = document;
        edited[field.key] = value;
        testing::write_bytes(file, edited.dump());
        ExpertPolicy::load(file);
      },
      [&](const io::Field& field, const io::Trial& trial, const std::string& error) {
        EXPECT_NE(error.find("expert.json"), std::string::npos) << error;
        // In range but refused: a list whose length does not fit the layers.
        if (!trial.in_range) {
          EXPECT_NE(error.find(field.key), std::string::npos) << field.key << ": " << error;
        }
      },
      [](const io::Field&, const io::Trial&) {}, /*through_text=*/true);
  EXPECT_GT(counts.refused, 0);
}

}  // namespace
}  // namespace maps::envs
