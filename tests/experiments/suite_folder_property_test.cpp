// Suite folders damaged at random (issue 41, item 6): suite.json (bytes and JSON structure), read back by `maps suite
// status`, `merge` and `run`, and a cell's result.json, which the suite trusts only when it is whole.
#include <gtest/gtest.h>

#include <set>
#include <string>

#include "experiments/suite/config.h"
#include "experiments/suite/folder.h"
#include "tests/common/mutations.h"
#include "tests/common/temp_folder.h"

namespace maps::experiments {
namespace {

using Json = nlohmann::json;

class SuiteFolderProperty : public TempFolderTest {
 protected:
  SuiteFolderProperty() : TempFolderTest("maps_suite_folder_property_") {}
};

bool manifest_holds(const Suite& suite, std::string& why) {
  std::set<std::string> names;
  for (const SuiteCell& cell : suite.cells) {
    if (cell.name.empty() || !names.insert(cell.name).second) {
      why = "cell names";
      return false;
    }
    if (cell.index < 0 || cell.demos < 1 || cell.subsample < 1) {
      why = "cell " + cell.name + ": index, demos or subsample out of range";
      return false;
    }
  }
  return true;
}

TEST_F(SuiteFolderProperty, ADamagedManifestIsRefusedNamingItOrReadWithItsInvariants) {
  const Suite suite = load_suite(std::string(MAPS_SOURCE_DIR) + "/experiments/suites/tiny.json");
  write_or_check_manifest(dir_, suite);
  const std::string manifest = path("suite.json");
  const std::string original = testing::read_bytes(manifest);
  const Json document = Json::parse(original);
  Suite read;
  auto load = [&](const std::string&) { read = read_manifest(dir_); };
  auto holds = [&](std::string& why) { return manifest_holds(read, why); };
  testing::check_mutants(
      "suite.json bytes", original, manifest, testing::property_cases(150),
      [&](std::mt19937_64& rng, std::string& how) { return testing::byte_mutant(original, rng, how); }, load, holds);
  testing::check_mutants(
      "suite.json structure", original, manifest, testing::property_cases(300),
      [&](std::mt19937_64& rng, std::string& how) { return testing::json_mutant(document, rng, how).dump(1); }, load,
      holds);
}

TEST_F(SuiteFolderProperty, ADamagedResultIsNotTrustedAndSaysWhy) {
  const Suite suite = load_suite(std::string(MAPS_SOURCE_DIR) + "/experiments/suites/tiny.json");
  const SuiteCell& cell = suite.cells.front();
  const Json result = {
      {"format", kCellFormat},
      {"cell", cell.identity()},
      {"config", cell.request},
      {"train", {{"steps", 60}, {"best_step", 40}, {"best_validation_bc", 0.5}}},
      {"eval", {{"mean_score", 0.25}, {"best_step", 40}, {"tasks", {{{"task", "a"}, {"score", 0.25}}}}}}};
  const std::string file = path("result.json");
  testing::write_bytes(file, result.dump(1));
  ASSERT_TRUE(read_result(dir_, cell).has_value());
  const std::string original = result.dump(1);
  std::optional<Json> read;
  // read_result never throws: an untrusted result is "not finished" (the cell runs again) with the reason given.
  auto load = [&](const std::string&) {
    std::string damage;
    read = read_result(dir_, cell, &damage);
    if (!read) throw std::runtime_error(damage);
  };
  auto holds = [&](std::string& why) {
    why = read->dump().substr(0, 200);
    return read->at("format") == kCellFormat && read->at("cell").at("name") == cell.name &&
           read->at("eval").at("mean_score").is_number();
  };
  testing::check_mutants(
      "result.json bytes", original, file, testing::property_cases(150),
      [&](std::mt19937_64& rng, std::string& how) { return testing::byte_mutant(original, rng, how); }, load, holds);
  testing::check_mutants(
      "result.json structure", original, file, testing::property_cases(300),
      [&](std::mt19937_64& rng, std::string& how) { return testing::json_mutant(result, rng, how).dump(1); }, load,
      holds);
}

}  // namespace
}  // namespace maps::experiments
