#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "experiments/run/run_folder.h"
#include "experiments/suite/folder.h"
#include "tests/common/temp_folder.h"

namespace maps::experiments {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;

class RetireCell : public TempFolderTest {
 protected:
  RetireCell() : TempFolderTest("maps_suite_folder_") {}

  void write(const std::string& name, const std::string& text) const { std::ofstream(dir_ / name) << text; }
  static std::string read(const fs::path& path) {
    std::ifstream in(path);
    std::stringstream text;
    text << in.rdbuf();
    return text.str();
  }
  // A finished cell as the suite leaves it, with the resume state and logs a rerun must not see.
  void finish(const std::string& finished, const std::string& curve) const {
    write_json_file((dir_ / "result.json").string(), {{"finished", finished}, {"eval", {{"mean_score", 0.5}}}});
    write("curve.csv", curve);
    write("last.ckpt", "resume state");
    write("train.log", "log");
    write(".lock", "");
  }
};

class Manifest : public TempFolderTest {
 protected:
  Manifest() : TempFolderTest("maps_suite_manifest_") {}
};

// A manifest written by hand may give a cell's run config in part: it is read resolved, every key there, so that
// status, plan and the cost table can read any key of it (an absent one was undefined behaviour in Release builds;
// an assertion build stopped on it).
TEST_F(Manifest, ACellsRunConfigIsReadResolved) {
  const Json cell{{"index", 0},       {"name", "gravity/maps_d2_s0"},
                  {"grid", "g"},      {"set", "gravity"},
                  {"method", "maps"}, {"variant", "base"},
                  {"demos", 2},       {"subsample", 10},
                  {"seed", 0},        {"request", {{"method", "maps"}, {"data", {{"file", "data/gravity.h5"}}}}}};
  write_json_file((dir_ / "suite.json").string(),
                  {{"format", kSuiteFormat}, {"config", Json::object()}, {"cells", Json::array({cell})}});
  const Suite suite = read_manifest(dir_);
  ASSERT_EQ(suite.cells.size(), 1u);
  const Json& request = suite.cells[0].request;
  EXPECT_EQ(request.at("train").at("steps"), 30000);
  EXPECT_TRUE(request.at("eval").contains("episodes"));
  EXPECT_EQ(request.at("data").at("file"), "data/gravity.h5");
  EXPECT_TRUE(same_run_config(request, cell["request"]));
}

// Why a result or a folder is refused names the keys that differ and both values, resolved (a key one of them
// leaves at its default is no difference), at most three and how many more.
TEST(RunConfigDifferences, NameTheKeysAndBothValues) {
  const Json base{{"method", "maps"}, {"data", {{"file", "data/gravity.h5"}}}};
  Json theirs = base, ours = base;
  theirs["train"] = {{"steps", 5}};
  ours["train"] = {{"steps", 20000}};
  ours["maml"] = {{"query_per_task", 40}};
  ours["eval"] = {{"episodes", 100}};  // the default: no difference
  EXPECT_FALSE(same_run_config(theirs, ours));
  EXPECT_EQ(run_config_differences(theirs, ours, "its config", "the suite's"),
            "maml.query_per_task: 160 in its config, 40 in the suite's; train.steps: 5 in its config, 20000 in the "
            "suite's");
  ours["train"]["validate_every"] = 7;
  ours["seed"] = 9;
  EXPECT_EQ(run_config_differences(theirs, ours, "a", "b"),
            "maml.query_per_task: 160 in a, 40 in b; seed: 0 in a, 9 in b; train.steps: 5 in a, 20000 in b; and 1 "
            "more");
  EXPECT_EQ(run_config_differences(base, base, "a", "b"), "");
  const std::string unreadable = run_config_differences(Json{{"method", "mapz"}}, base, "a", "b");
  EXPECT_EQ(unreadable.rfind("a is no run config (", 0), 0u) << unreadable;
}

TEST_F(RetireCell, MovesTheResultsToAFolderNamedForWhenTheyFinished) {
  finish("2026-11-27T10:20:30Z", "step,loss\n50,0.1\n");
  const fs::path kept = retire_cell(dir_);
  EXPECT_EQ(kept, dir_ / "replaced" / "2026-11-27T10-20-30Z");
  EXPECT_EQ(read_json_file((kept / "result.json").string())["finished"], "2026-11-27T10:20:30Z");
  EXPECT_EQ(read(kept / "curve.csv"), "step,loss\n50,0.1\n");
  // The rest is cleared for the rerun; the lock stays (the caller holds it).
  std::vector<std::string> left;
  for (const auto& entry : fs::directory_iterator(dir_)) left.push_back(entry.path().filename().string());
  std::sort(left.begin(), left.end());
  EXPECT_EQ(left, (std::vector<std::string>{".lock", "replaced"}));
}

TEST_F(RetireCell, ASecondRetiredResultOfTheSameTimeGetsAFolderOfItsOwn) {
  finish("2026-11-27T10:20:30Z", "first");
  retire_cell(dir_);
  finish("2026-11-27T10:20:30Z", "second");
  const fs::path kept = retire_cell(dir_);
  EXPECT_EQ(kept.filename(), "2026-11-27T10-20-30Z-2");
  EXPECT_EQ(read(dir_ / "replaced" / "2026-11-27T10-20-30Z" / "curve.csv"), "first");
  EXPECT_EQ(read(kept / "curve.csv"), "second");
  // clear_cell, as a damaged rerun does, keeps the record.
  clear_cell(dir_);
  EXPECT_TRUE(fs::exists(kept / "result.json"));
}

TEST_F(RetireCell, AFolderHalfMovedByACrashIsTakenUpAgain) {
  finish("2026-11-27T10:20:30Z", "curve");
  // curve.csv moves first, result.json last: a crash between them leaves the cell finished and the folder without
  // result.json.
  fs::create_directories(dir_ / "replaced" / "2026-11-27T10-20-30Z");
  fs::rename(dir_ / "curve.csv", dir_ / "replaced" / "2026-11-27T10-20-30Z" / "curve.csv");
  const fs::path kept = retire_cell(dir_);
  EXPECT_EQ(kept.filename(), "2026-11-27T10-20-30Z");
  EXPECT_TRUE(fs::exists(kept / "result.json"));
  EXPECT_EQ(read(kept / "curve.csv"), "curve");
}

TEST_F(RetireCell, AFinishTimeThatIsNoTimeDoesNotNameTheFolder) {
  for (const std::string finished : {"../../escape", "", "2026-11-27 10:20:30", "2026-11-27T10:20:30Z/x"}) {
    SCOPED_TRACE(finished);
    fs::remove_all(dir_ / "replaced");
    finish(finished, "curve");
    EXPECT_EQ(retire_cell(dir_), dir_ / "replaced" / "unknown");
  }
  // Nor does a result.json that is damaged or lacks the time.
  fs::remove_all(dir_ / "replaced");
  write("result.json", "{\"finished\": ");
  EXPECT_EQ(retire_cell(dir_), dir_ / "replaced" / "unknown");
  EXPECT_EQ(read(dir_ / "replaced" / "unknown" / "result.json"), "{\"finished\": ");
  fs::remove_all(dir_ / "replaced");
  write_json_file((dir_ / "result.json").string(), {{"finished", 7}});
  EXPECT_EQ(retire_cell(dir_), dir_ / "replaced" / "unknown");
}

// A suite of cells in one set, each named by a letter; `sources` names the cell each starts from (init.run).
class SourceGroups : public TempFolderTest {
 protected:
  SourceGroups() : TempFolderTest("maps_suite_groups_") {}

  void make(const std::vector<std::pair<std::string, std::string>>& cells) {
    suite_.cells.clear();
    for (const auto& [name, source] : cells) {
      SuiteCell cell;
      cell.index = static_cast<int>(suite_.cells.size());
      // Built from characters: GCC 12 warns falsely of an overflowing copy (-Wstringop-overflow) for a literal
      // assigned to a string here when this file is compiled in a batch with others (the unity build).
      cell.set.assign(1, 's');
      cell.name = cell.set + "/" + name;
      cell.request = {{"method", "maps"}};
      if (!source.empty()) cell.request["init"] = {{"run", "../" + source}, {"checkpoint", "best.ckpt"}};
      suite_.cells.push_back(cell);
    }
  }
  const SuiteCell& cell(const std::string& name) const {
    return *std::find_if(suite_.cells.begin(), suite_.cells.end(),
                         [&](const SuiteCell& c) { return c.name == "s/" + name; });
  }
  fs::path folder(const std::string& name) const { return cell_dir(dir_, cell(name)).lexically_normal(); }
  // A finished cell as read_result accepts it; with its best.ckpt or without (the results keep none).
  void finish(const std::string& name, bool checkpoint) const {
    const SuiteCell& c = cell(name);
    fs::create_directories(folder(name));
    write_json_file((folder(name) / "result.json").string(),
                    {{"format", kCellFormat},
                     {"cell", {{"name", c.name}}},
                     {"config", c.request},
                     {"finished", "2026-11-28T10:00:00Z"},
                     {"train", {{"steps", 100}, {"best_step", 50}, {"best_validation_bc", 0.1}}},
                     {"eval", {{"mean_score", 0.5}, {"best_step", 50}, {"tasks", {{{"task", "t"}, {"score", 0.5}}}}}}});
    if (checkpoint) std::ofstream(folder(name) / "best.ckpt") << "weights";
  }
  bool finished(const std::string& name) const { return read_result(folder(name), cell(name)).has_value(); }
  bool retired(const std::string& name) const {
    return fs::exists(folder(name) / "replaced" / "2026-11-28T10-00-00Z" / "result.json");
  }
  // The cells a config makes: all of the suite's but those named in `dropped`.
  std::vector<const SuiteCell*> config(const std::set<std::string>& dropped = {}) const {
    std::vector<const SuiteCell*> cells;
    for (const auto& c : suite_.cells)
      if (!dropped.count(c.name.substr(2))) cells.push_back(&c);
    return cells;
  }
  std::set<fs::path> retire(const std::set<std::string>& dropped = {}) const {
    return retire_sources_without_checkpoint(dir_, config(dropped));
  }
  // What status says runs again, read before retire() runs, over this folder and `more_dirs`.
  CellsRunAgain run_again(const std::set<std::string>& dropped = {},
                          const std::vector<fs::path>& more_dirs = {}) const {
    std::set<std::string> done;
    for (const auto& c : suite_.cells)
      if (finished(c.name.substr(2))) done.insert(c.name);
    std::vector<fs::path> dirs{dir_};
    dirs.insert(dirs.end(), more_dirs.begin(), more_dirs.end());
    return cells_to_run_again(config(dropped), done, dirs);
  }
  static std::set<std::string> short_names(const std::set<std::string>& names) {
    std::set<std::string> out;
    for (const auto& name : names) out.insert(name.substr(2));
    return out;
  }
  // The finished cells that run again (by short name).
  std::set<std::string> predicted(const std::set<std::string>& dropped = {},
                                  const std::vector<fs::path>& more_dirs = {}) const {
    return short_names(run_again(dropped, more_dirs).finished);
  }
  // The unfinished cells of the groups that run again, which start from nothing (by short name).
  std::set<std::string> restarted() const { return short_names(run_again().restarted); }
  std::set<std::string> retired_cells() const {
    std::set<std::string> out;
    for (const auto& c : suite_.cells)
      if (retired(c.name.substr(2))) out.insert(c.name.substr(2));
    return out;
  }
  std::vector<std::string> names(const std::vector<const SuiteCell*>& cells) const {
    std::vector<std::string> out;
    for (const auto* c : cells) out.push_back(c->name.substr(2));
    return out;
  }

  Suite suite_;
};

TEST_F(SourceGroups, SourcesFirstPutsEveryCellAfterItsChainOfSources) {
  make({{"c", "b"}, {"x", ""}, {"b", "a"}, {"a", ""}, {"d", "a"}});
  // c waits for its chain (a, then b) to be placed; the rest keep their order.
  EXPECT_EQ(names(sources_first(suite_)), (std::vector<std::string>{"a", "b", "c", "x", "d"}));
  // A cycle (a hand-written init.run naming each other) keeps every cell once.
  make({{"p", "q"}, {"q", "p"}, {"r", ""}});
  EXPECT_EQ(names(sources_first(suite_)), (std::vector<std::string>{"q", "p", "r"}));
}

TEST_F(SourceGroups, DescendantsFollowChainsNearestFirst) {
  make({{"a", ""}, {"b", "a"}, {"c", "b"}, {"d", "a"}, {"e", ""}});
  std::map<fs::path, std::vector<const SuiteCell*>> dependants;
  for (const auto& c : suite_.cells)
    if (const fs::path source = source_dir(cell_dir(dir_, c), c); !source.empty()) dependants[source].push_back(&c);
  std::vector<std::string> found;
  for (const auto& [dir, c] : suite_descendants(dependants, dir_, folder("a"))) {
    EXPECT_EQ(dir, folder(c->name.substr(2)));
    found.push_back(c->name.substr(2));
  }
  EXPECT_EQ(found, (std::vector<std::string>{"b", "d", "c"}));
}

TEST_F(SourceGroups, ASourceWithoutItsCheckpointRunsAgainWithTheCellsFromIt) {
  make({{"a", ""}, {"b", "a"}, {"c", "a"}, {"e", ""}, {"f", "e"}});
  finish("a", false);
  finish("b", false);  // finished from a: runs again from a's rerun
  fs::create_directories(folder("c"));
  std::ofstream(folder("c") / "last.ckpt") << "part-trained from the earlier a";
  finish("e", false);
  finish("f", false);  // every cell from e is finished: e stays
  EXPECT_EQ(predicted(), (std::set<std::string>{"a", "b"}));
  EXPECT_EQ(restarted(), (std::set<std::string>{"c"}));
  EXPECT_TRUE(retire().empty());
  EXPECT_EQ(retired_cells(), (std::set<std::string>{"a", "b"}));
  EXPECT_TRUE(retired("a"));
  EXPECT_TRUE(retired("b"));
  EXPECT_FALSE(finished("a"));
  EXPECT_FALSE(finished("b"));
  EXPECT_FALSE(fs::exists(folder("c") / "last.ckpt"));
  EXPECT_TRUE(finished("e"));
  EXPECT_TRUE(finished("f"));
  // Run again, nothing changes: a is left to run, which writes the checkpoint its cells need.
  EXPECT_TRUE(retire().empty());
  EXPECT_FALSE(fs::exists(folder("a") / "replaced" / "2026-11-28T10-00-00Z-2"));
}

TEST_F(SourceGroups, ASourceWithItsCheckpointStays) {
  make({{"a", ""}, {"b", "a"}});
  finish("a", true);
  EXPECT_TRUE(predicted().empty());
  retire();
  EXPECT_TRUE(finished("a"));
  EXPECT_FALSE(retired("a"));
}

TEST_F(SourceGroups, AChainRunsAgainFromItsRoot) {
  // c is left and starts from b, whose checkpoint is gone; b can run again only from a, whose checkpoint is gone
  // too: a, b and everything from either run again.
  make({{"a", ""}, {"b", "a"}, {"c", "b"}, {"d", "b"}, {"g", "a"}});
  finish("a", false);
  finish("b", false);
  finish("d", false);
  finish("g", true);
  EXPECT_EQ(predicted(), (std::set<std::string>{"a", "b", "d", "g"}));
  EXPECT_TRUE(retire().empty());
  EXPECT_EQ(retired_cells(), (std::set<std::string>{"a", "b", "d", "g"}));
  for (const char* name : {"a", "b", "d", "g"}) {
    SCOPED_TRACE(name);
    EXPECT_TRUE(retired(name));
    EXPECT_FALSE(finished(name));
  }
}

TEST_F(SourceGroups, ACellTheConfigNoLongerMakesLeavesItsSourceAlone) {
  // c, left, starts from b (checkpoint gone) but the config dropped it: it will not run, so b and a stay; e, left and
  // in the config, starts from d (checkpoint gone) through nothing else: d runs again.
  make({{"a", ""}, {"b", "a"}, {"c", "b"}, {"d", ""}, {"e", "d"}});
  finish("a", false);
  finish("b", false);
  finish("d", false);
  EXPECT_EQ(predicted({"c"}), (std::set<std::string>{"d"}));
  EXPECT_EQ(predicted(), (std::set<std::string>{"a", "b", "d"}));
  EXPECT_TRUE(retire({"c"}).empty());
  EXPECT_EQ(retired_cells(), (std::set<std::string>{"d"}));
}

TEST_F(SourceGroups, ATrailingSeparatorNamesTheSameSource) {
  make({{"a", ""}, {"b", "a/"}});  // init.run "../a/"
  EXPECT_EQ(source_dir(folder("b"), cell("b")), folder("a"));
  finish("a", false);
  EXPECT_EQ(predicted(), (std::set<std::string>{"a"}));
  EXPECT_TRUE(retire().empty());
  EXPECT_EQ(retired_cells(), (std::set<std::string>{"a"}));
}

TEST_F(SourceGroups, StatusFindsTheCheckpointInAnyOfItsFolders) {
  // Status over two folders (a clone of the results and the machine that ran it): a's checkpoint in the second is
  // enough for b to start from once merged, so a does not count as running again.
  make({{"a", ""}, {"b", "a"}});
  finish("a", false);
  const fs::path other = dir_ / "other";
  fs::create_directories(cell_dir(other, cell("a")));
  std::ofstream(cell_dir(other, cell("a")) / "best.ckpt") << "weights";
  EXPECT_TRUE(predicted({}, {other}).empty());
  EXPECT_EQ(predicted(), (std::set<std::string>{"a"}));
}

TEST_F(SourceGroups, AGroupAnotherProcessHoldsIsLeftToIt) {
  make({{"a", ""}, {"b", "a"}, {"c", "b"}, {"d", "a"}});
  finish("a", false);
  finish("b", false);
  const CellLock running(folder("c"));  // as another process running c (its own lock file descriptor)
  ASSERT_TRUE(running.held());
  const std::set<fs::path> held = retire();
  EXPECT_EQ(held, (std::set<fs::path>{folder("a"), folder("b"), folder("c"), folder("d")}));
  EXPECT_TRUE(finished("a"));
  EXPECT_TRUE(finished("b"));
  EXPECT_FALSE(retired("a"));
}

TEST_F(SourceGroups, ARetirementStoppedBeforeTheSourceIsTakenUpAgain) {
  // A run killed after retiring b (a dependant) but before a (the source) leaves a finished a without its checkpoint
  // and b to run: the next run retires a, and keeps b's earlier result where it is.
  make({{"a", ""}, {"b", "a"}});
  finish("a", false);
  finish("b", false);
  retire_cell(folder("b"));
  EXPECT_TRUE(retire().empty());
  EXPECT_TRUE(retired("a"));
  EXPECT_TRUE(retired("b"));
  EXPECT_FALSE(fs::exists(folder("b") / "replaced" / "2026-11-28T10-00-00Z-2"));
}

TEST_F(SourceGroups, AChainStopsAtASourceWhoseCheckpointIsThere) {
  make({{"a", ""}, {"b", "a"}, {"c", "b"}});
  finish("a", false);
  finish("b", true);
  EXPECT_TRUE(retire().empty());
  EXPECT_TRUE(finished("a"));
  EXPECT_TRUE(finished("b"));
}

TEST_F(SourceGroups, AChainWithACellHeldElsewhereIsLeftWhole) {
  // c is left, so b runs again, and so must a (its checkpoint is gone too), with d, which another process holds:
  // nothing is retired, b's part of the group included.
  make({{"a", ""}, {"b", "a"}, {"c", "b"}, {"d", "a"}});
  finish("a", false);
  finish("b", false);
  finish("d", false);
  {
    const CellLock running(folder("d"));
    EXPECT_EQ(retire(), (std::set<fs::path>{folder("a"), folder("b"), folder("c"), folder("d")}));
    EXPECT_TRUE(finished("a"));
    EXPECT_TRUE(finished("b"));
  }
  // The locks this process took are let go: once d's runner has stopped, the next run takes the group.
  EXPECT_TRUE(retire().empty());
  EXPECT_TRUE(retired("a"));
  EXPECT_TRUE(retired("b"));
  EXPECT_TRUE(retired("d"));
}

TEST_F(SourceGroups, ACellWhoseSourceIsNoCellOfTheSuiteIsLeftToItsRun) {
  // init.run naming a folder the suite does not make (a run outside it): nothing here can rerun it.
  make({{"b", "outside"}});
  EXPECT_TRUE(retire().empty());
  EXPECT_FALSE(fs::exists(folder("b") / "replaced"));
}

}  // namespace
}  // namespace maps::experiments
