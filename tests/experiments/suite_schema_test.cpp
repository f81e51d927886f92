// Every key of the suite config schema tried with the edge values of its type (issue 41), generated from the schema.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <string>

#include "experiments/suite/config.h"
#include "experiments/suite/schema.h"
#include "io/config_schema.h"
#include "tests/common/schema_trials.h"

namespace maps::experiments {
namespace {

using Json = nlohmann::json;

// The keys that only a transfer grid takes (the second grid of the base suite, which teaches gravity/0.5 from the
// first grid's holdout runs).
bool on_transfer_grid(const std::string& key) {
  for (const char* k : {"grids[].new_task", "grids[].others_demos", "grids[].freeze", "grids[].module_lr_scale",
                        "grids[].source_variant"})
    if (key == k) return true;
  return false;
}

// The place of a key as parse_suite's errors name it ("grids[1].seeds", "sets.gravity.demos").
std::string error_path(const std::string& key) {
  std::string path = key;
  for (const auto& [from, to] : {std::pair<std::string, std::string>{"<set>", "gravity"}, {"<variant>", "v"}})
    if (const auto at = path.find(from); at != std::string::npos) path.replace(at, from.size(), to);
  if (path.rfind("grids[]", 0) == 0) path.replace(0, 7, on_transfer_grid(key) ? "grids[1]" : "grids[0]");
  return path;
}

// A valid suite with `value` at the schema key `key` ("<set>" is gravity, "<variant>" is v, "grids[]" the first grid,
// or the transfer grid for its keys).
Json suite_with(const std::string& key, const Json& value) {
  Json suite = Json::object();
  suite["sets"]["gravity"] = {{"data", {{"file", "g.h5"}}}, {"demos", {2}}};
  suite["grids"] = Json::array();
  suite["grids"].push_back({{"name", "plain"}, {"sets", {"gravity"}}, {"methods", {"maps"}}, {"seeds", {0}}});
  if (on_transfer_grid(key)) {
    suite["grids"][0]["holdout"] = {"gravity/0.5"};
    suite["grids"].push_back({{"name", "taught"},
                              {"sets", {"gravity"}},
                              {"methods", {"transfer"}},
                              {"new_task", {"gravity/0.5"}},
                              {"others_demos", 2},
                              {"demos", {1}},
                              {"seeds", {0}}});
  }
  std::string path = error_path(key);
  if (path.rfind("grids[", 0) == 0) path = "grids." + path.substr(6, 1) + path.substr(8);  // grids[1].x -> grids.1.x
  suite[io::key_pointer(path)] = value;
  return suite;
}

TEST(SuiteConfigSchema, EveryKeyTakesTheValuesOfItsRangeAndRefusesEveryOtherByName) {
  const io::WalkCounts counts = io::walk_schema(
      suite_config_schema(),
      [](const io::Field& field, const Json& value) { parse_suite(suite_with(field.key, value), "suite.json"); },
      [](const io::Field& field, const io::Trial& trial, const std::string& error) {
        const std::string what = field.key + " = " + trial.value.dump();
        const std::string path = error_path(field.key);
        if (!trial.in_range) {
          EXPECT_THAT(error, ::testing::HasSubstr(path)) << what;
          EXPECT_THAT(error, ::testing::AnyOf(::testing::HasSubstr("expected"), ::testing::HasSubstr("listed twice")))
              << what;
        } else {
          // A value the key's range allows may be refused by a rule across keys (a set the suite does not define, a
          // variant with no definition, method transfer without new_task), naming the key or its grid.
          EXPECT_THAT(error, ::testing::HasSubstr(path.substr(0, path.find(']') + 1))) << what;
        }
      },
      [](const io::Field&, const io::Trial&) {});
  EXPECT_GT(counts.tried, 300);
}

TEST(SuiteConfigSchema, AcceptedIntegersAreKeptAsGiven) {
  // 2^32 + 1 demonstrations wrapped to 1 in an int before the schema; now it is out of range, and the largest count
  // in range is kept as it is.
  EXPECT_THROW(parse_suite(suite_with("sets.<set>.demos", {4294967297LL}), "suite.json"), std::invalid_argument);
  const Suite suite = parse_suite(suite_with("grids[].seeds", {18446744073709551615ULL}), "suite.json");
  ASSERT_EQ(suite.cells.size(), 1u);
  EXPECT_EQ(suite.cells[0].seed, 18446744073709551615ULL);
}

TEST(SuiteConfigSchema, TheDocsTableIsTheSchemasOwn) {
  std::ifstream in(std::string(MAPS_SOURCE_DIR) + "/docs/suite.md");
  std::stringstream text;
  text << in.rdbuf();
  EXPECT_NE(text.str().find(io::markdown_table(suite_config_schema())), std::string::npos)
      << "docs/suite.md's table of keys is not `build/bin/maps schema suite-config --markdown`'s output: paste it";
}

}  // namespace
}  // namespace maps::experiments
