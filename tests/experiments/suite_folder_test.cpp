#include "experiments/suite_folder.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <sstream>

#include "experiments/run_folder.h"
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

}  // namespace
}  // namespace maps::experiments
