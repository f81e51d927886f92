// The plugin loader (experiments/process/plugins.h) on the test plugins of tests/plugins/: each refusal the docs promise
// (a missing file, no mark, another version, a dynamic-loader failure, a taken name) and a plugin's losses and
// methods reaching the run config, the suite config and provenance.

#include "experiments/process/plugins.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "envs/half_cheetah.h"
#include "envs/task_expert.h"
#include "envs/task_sets.h"
#include "experiments/run/provenance.h"
#include "experiments/suite/config.h"
#include "io/version.h"
#include "maps/policies/policy_registry.h"
#include "maps/selector/selector_loss.h"
#include "maps/training/run_config.h"
#include "tests/common/error_of.h"
#include "tests/common/temp_folder.h"

namespace maps::experiments {
namespace {

using ::testing::HasSubstr;
namespace fs = std::filesystem;

std::string plugin(const std::string& name) { return std::string(MAPS_TEST_PLUGIN_DIR) + "/lib" + name + ".so"; }

bool has_selector_loss(const std::string& name) {
  for (const auto& loss : core::selector_losses())
    if (loss.name == name) return true;
  return false;
}

class PluginsTest : public TempFolderTest {
 protected:
  PluginsTest() : TempFolderTest("maps_plugins_test_") {}
};

TEST_F(PluginsTest, APluginRegistersItsLossAndMethodWithItsPathAsOrigin) {
  const LoadedPlugin& loaded = load_plugin(plugin("maps_test_plugin"), "test");
  EXPECT_EQ(loaded.path, fs::canonical(plugin("maps_test_plugin")).string());
  EXPECT_EQ(loaded.version, MAPS_VERSION);
  EXPECT_EQ(loaded.sha256, sha256_of_file(plugin("maps_test_plugin")));
  EXPECT_THAT(loaded.registered, ::testing::ElementsAre("selector loss plugin_squared_scores", "method plugin_linear",
                                                        "task set plugin_cheetah"));
  EXPECT_EQ(core::selector_loss_origin("plugin_squared_scores"), loaded.path);
  EXPECT_EQ(core::policy_method_origin("plugin_linear"), loaded.path);
  EXPECT_EQ(core::selector_loss_origin("share"), "");
  EXPECT_EQ(core::make_selector_loss("plugin_squared_scores")->name(), "plugin_squared_scores");
  // The built-ins are still there, first.
  EXPECT_EQ(core::selector_losses().front().name, "share");
  EXPECT_EQ(core::policy_methods().front().name, "maps");
}

TEST_F(PluginsTest, APluginsTaskSetHasEnvsAndExpertsLikeABuiltIns) {
  EXPECT_THROW(envs::task_names("plugin_cheetah"), std::invalid_argument);
  const LoadedPlugin& loaded = load_plugin(plugin("maps_test_plugin"), "test");
  const auto sets = envs::task_set_names();
  EXPECT_THAT(sets, ::testing::ElementsAre("gravity", "modified", "mt10", "plugin_cheetah"));
  EXPECT_THAT(envs::task_names("plugin_cheetah"), ::testing::ElementsAre("plugin_cheetah/g0_9", "plugin_cheetah/g1_1"));
  EXPECT_EQ(envs::task_set_origin("plugin_cheetah"), loaded.path);
  EXPECT_EQ(envs::task_set_origin("gravity"), "");
  EXPECT_FALSE(envs::scored_by_success("plugin_cheetah"));
  EXPECT_TRUE(envs::scored_by_success("mt10"));
  EXPECT_EQ(envs::task_index("plugin_cheetah/g1_1"), 1);
  const auto env = envs::make_env("plugin_cheetah/g1_1");
  EXPECT_EQ(env->spec().task, "plugin_cheetah/g1_1");
  const envs::TaskExpert expert = envs::load_task_expert("plugin_cheetah/g1_1");
  EXPECT_EQ(expert.task, "plugin_cheetah/g1_1");
  EXPECT_EQ(expert.mean_action(env->reset(1)).size(), env->spec().action_size);
}

TEST_F(PluginsTest, ATaskSetIsRefusedWithoutTasksOrWithTasksOfAnotherName) {
  envs::TaskSetDefinition empty;
  empty.name = "empty_set";
  EXPECT_THAT(error_of([&] { envs::register_task_set(empty); }), HasSubstr("task set 'empty_set': it has no tasks"));
  const envs::EnvFactory cheetah = [](const std::string& name, std::int64_t index) -> std::unique_ptr<envs::Env> {
    return std::make_unique<envs::HalfCheetahEnv>(name, index);
  };
  envs::TaskSetDefinition misnamed{"good_set", {{"other/t", cheetah}}};
  EXPECT_THAT(error_of([&] { envs::register_task_set(misnamed); }),
              HasSubstr("task 'other/t' is not named 'good_set/<task>'"));
  envs::TaskSetDefinition taken = misnamed;
  taken.name = "gravity";
  taken.tasks[0].name = "gravity/x";
  EXPECT_THAT(error_of([&] { envs::register_task_set(taken); }), HasSubstr("the name is taken"));
}

TEST_F(PluginsTest, ASecondLoadOfTheSamePluginIsTheFirst) {
  const LoadedPlugin& first = load_plugin(plugin("maps_test_plugin"), "test");
  // Another spelling of the same file (through its folder's "..").
  const std::string again = std::string(MAPS_TEST_PLUGIN_DIR) + "/../plugins/libmaps_test_plugin.so";
  const LoadedPlugin& second = load_plugin(again, "test");
  EXPECT_EQ(&first, &second);
  EXPECT_EQ(loaded_plugins().size(), 1u);
}

TEST_F(PluginsTest, AMissingFileIsNamedWithWhatNamedIt) {
  const std::string error = error_of([&] { load_plugin(path("libnot_there.so"), "--config 'a.json'"); });
  EXPECT_THAT(error, HasSubstr("--config 'a.json'"));
  EXPECT_THAT(error, HasSubstr(path("libnot_there.so") + "' does not exist"));
}

TEST_F(PluginsTest, AFolderIsNotAPlugin) {
  EXPECT_THAT(error_of([&] { load_plugin(dir_.string(), "test"); }), HasSubstr("is not a file"));
}

TEST_F(PluginsTest, ALibraryWithoutTheMarkIsRefusedAndNotLoaded) {
  const std::string error = error_of([&] { load_plugin(plugin("maps_test_plugin_unmarked"), "test"); });
  EXPECT_THAT(error, HasSubstr("is not a maps plugin: it has no MAPS_PLUGIN() mark"));
  EXPECT_FALSE(has_selector_loss("plugin_without_mark"));  // its static initialiser never ran
  EXPECT_TRUE(loaded_plugins().empty());
}

TEST_F(PluginsTest, AFileThatIsNoLibraryIsRefused) {
  std::ofstream(path("libtext.so")) << "just text, no library";
  EXPECT_THAT(error_of([&] { load_plugin(path("libtext.so"), "test"); }), HasSubstr("is not a maps plugin"));
  // The mark's text alone does not make a library.
  std::ofstream(path("libfake.so")) << "maps-plugin-abi:" << MAPS_VERSION << '\0' << "more text";
  EXPECT_THAT(error_of([&] { load_plugin(path("libfake.so"), "test"); }), HasSubstr("could not be loaded"));
}

TEST_F(PluginsTest, APluginOfAnotherVersionIsRefusedNamingBothBeforeItsCodeRuns) {
  const std::string error = error_of([&] { load_plugin(plugin("maps_test_plugin_old"), "test"); });
  EXPECT_THAT(error, HasSubstr("was built against maps 0.0.1, and this is maps " MAPS_VERSION));
  EXPECT_THAT(error, HasSubstr("rebuild it"));
  EXPECT_FALSE(has_selector_loss("plugin_from_another_version"));
}

TEST_F(PluginsTest, APluginTheDynamicLoaderRefusesIsNamedWithItsMessage) {
  const std::string error = error_of([&] { load_plugin(plugin("maps_test_plugin_unresolved"), "test"); });
  EXPECT_THAT(error, HasSubstr("could not be loaded"));
  EXPECT_THAT(error, HasSubstr("maps_test_function_nobody_defines"));
}

TEST_F(PluginsTest, APluginTakingABuiltInsNameIsRefusedNamingBoth) {
  const std::string error = error_of([&] { load_plugin(plugin("maps_test_plugin_clash"), "test"); });
  EXPECT_THAT(error, HasSubstr("its registrations were refused"));
  EXPECT_THAT(error, HasSubstr("selector loss 'share'"));
  EXPECT_THAT(error, HasSubstr("the name is taken (by the built-in"));
  // The built-in is untouched and the program's own registries still work.
  EXPECT_EQ(core::selector_loss_origin("share"), "");
  EXPECT_EQ(core::make_selector_loss("share")->name(), "share");
}

TEST_F(PluginsTest, AConfigsRelativePluginsAreTakenFromItsFolderAndMadeAbsolute) {
  fs::create_directories(dir_ / "plugins");
  fs::copy_file(plugin("maps_test_plugin"), dir_ / "plugins" / "libmine.so");
  const nlohmann::json config{{"method", "plugin_linear"}, {"plugins", {"plugins/libmine.so"}}};
  const nlohmann::json loaded = load_config_plugins(config, dir_.string(), "--config 'x.json'");
  EXPECT_EQ(loaded["plugins"], nlohmann::json::array({fs::canonical(dir_ / "plugins" / "libmine.so").string()}));
  EXPECT_EQ(loaded["method"], "plugin_linear");
  // The run config now accepts the plugin's method and loss, and keeps the list.
  nlohmann::json run = loaded;
  run["data"] = {{"file", "d.h5"}};
  const core::RunConfig parsed = core::parse_run_config(run);
  EXPECT_EQ(parsed.method, "plugin_linear");
  EXPECT_EQ(core::to_json(parsed)["plugins"], loaded["plugins"]);
  run["method"] = "maps";
  run["maps"] = {{"selector_losses", {{"plugin_squared_scores", 0.5}}}};
  EXPECT_EQ(core::parse_run_config(run).maps.selector_losses.size(), 1u);
  // A missing one is named with the config and the path it was looked for at.
  const std::string error = error_of([&] {
    load_config_plugins({{"plugins", {"libgone.so"}}}, dir_.string(), "--config 'x.json'");
  });
  EXPECT_THAT(error,
              HasSubstr("--config 'x.json' (config plugins): plugin '" + path("libgone.so") + "' does not exist"));
}

TEST_F(PluginsTest, AConfigsPluginsMustBeAListOfPaths) {
  for (const nlohmann::json& bad : {nlohmann::json("libmine.so"), nlohmann::json({1}), nlohmann::json({""})})
    EXPECT_THAT(error_of([&] {
                  load_config_plugins({{"plugins", bad}}, ".", "c.json");
                }),
                HasSubstr("c.json: config plugins: expected a list of paths to shared libraries"))
        << bad.dump();
  // Without the key, nothing is loaded.
  EXPECT_EQ(load_config_plugins({{"method", "maps"}}, ".", "c.json"), nlohmann::json({{"method", "maps"}}));
  EXPECT_TRUE(loaded_plugins().empty());
}

TEST_F(PluginsTest, WithoutItsPluginAConfigNamingItsMethodIsRefusedListingTheKnownOnes) {
  const std::string error = error_of([] {
    core::parse_run_config({{"method", "plugin_linear"}, {"data", {{"file", "d.h5"}}}});
  });
  EXPECT_THAT(error, HasSubstr("config method"));
  EXPECT_THAT(error, HasSubstr("\"maps\""));
}

TEST_F(PluginsTest, ProvenanceNamesEachLoadedPluginWithItsDigest) {
  EXPECT_FALSE(provenance_record().contains("plugins"));
  load_plugin(plugin("maps_test_plugin"), "test");
  const nlohmann::json record = provenance_record();
  ASSERT_EQ(record["plugins"].size(), 1u);
  EXPECT_EQ(record["plugins"][0]["path"], fs::canonical(plugin("maps_test_plugin")).string());
  EXPECT_EQ(record["plugins"][0]["sha256"], sha256_of_file(plugin("maps_test_plugin")));
  EXPECT_EQ(record["plugins"][0]["built_against"], MAPS_VERSION);
  EXPECT_EQ(record["plugins"][0]["registered"][1], "method plugin_linear");
}

nlohmann::json suite_naming(const nlohmann::json& plugins) {
  return {{"plugins", plugins},
          {"sets", {{"gravity", {{"data", {{"file", "data/gravity.h5"}}}, {"demos", {5}}}}}},
          {"grids", {{{"name", "g"}, {"sets", {"gravity"}}, {"methods", {"plugin_linear"}}, {"seeds", {0}}}}}};
}

TEST_F(PluginsTest, ASuiteLoadsItsPluginsFromItsFolderAndGivesThemToEveryCell) {
  fs::copy_file(plugin("maps_test_plugin"), dir_ / "libmine.so");
  std::ofstream(path("suite.json")) << suite_naming({"libmine.so"}).dump();
  const Suite suite = load_suite(path("suite.json"));
  ASSERT_EQ(suite.cells.size(), 1u);
  EXPECT_EQ(suite.cells[0].method, "plugin_linear");
  EXPECT_EQ(suite.cells[0].request["plugins"], nlohmann::json::array({fs::canonical(dir_ / "libmine.so").string()}));
}

TEST_F(PluginsTest, ASuiteNamesItsPluginsAtItsTopOnly) {
  nlohmann::json suite = suite_naming(nlohmann::json::array());
  suite["grids"][0]["methods"] = {"maps"};
  suite["defaults"] = {{"plugins", {"libmine.so"}}};
  EXPECT_THAT(error_of([&] { parse_suite(suite, "s.json"); }),
              HasSubstr("s.json.defaults.plugins: a suite names its plugins at its top"));
  suite.erase("defaults");
  suite["variants"] = {{"v", {{"plugins", {"libmine.so"}}}}};
  EXPECT_THAT(error_of([&] { parse_suite(suite, "s.json"); }), HasSubstr("s.json.variants.v.plugins"));
  // And a missing one is named.
  std::ofstream(path("suite.json")) << suite_naming({"libgone.so"}).dump();
  EXPECT_THAT(error_of([&] { load_suite(path("suite.json")); }), HasSubstr(path("libgone.so") + "' does not exist"));
}

}  // namespace
}  // namespace maps::experiments
