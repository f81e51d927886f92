#include "experiments/run/training_attempts.h"

#include <gtest/gtest.h>

#include <fstream>

#include "tests/common/temp_folder.h"

namespace maps::experiments {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;

class TrainingAttempts : public TempFolderTest {
 protected:
  TrainingAttempts() : TempFolderTest("maps_training_attempts_") {}
  void write_provenance(const std::string& text) const { std::ofstream(dir_ / "provenance.json") << text; }
};

Json train_record(const std::string& cpu, long long start_step, long long steps) {
  return {{"subcommand", "train"},
          {"cpu", cpu},
          {"started_utc", "2026-11-27T00:00:00Z"},
          {"threads", 1},
          {"host", "vm-1"},
          {"start_step", start_step},
          {"steps", steps},
          {"float32_gemm_kernel", "avx2"}};
}

TEST_F(TrainingAttempts, NoProvenanceFileIsNoAttempts) { EXPECT_EQ(training_attempts(dir_), Json::array()); }

TEST_F(TrainingAttempts, EveryTrainingProcessWithItsMachineAndSteps) {
  write_provenance(Json::array({train_record("CPU A", 0, 20000), train_record("CPU B", 10500, 20000)}).dump());
  const Json attempts = training_attempts(dir_);
  ASSERT_EQ(attempts.size(), 2U);
  EXPECT_EQ(attempts[0]["cpu"], "CPU A");
  EXPECT_EQ(attempts[1]["cpu"], "CPU B");
  EXPECT_EQ(attempts[1]["start_step"], 10500);
  EXPECT_EQ(attempts[1]["steps"], 20000);
  EXPECT_EQ(attempts[1]["float32_gemm_kernel"], "avx2");
  EXPECT_FALSE(attempts[0].contains("host"));  // the VM's name says nothing of where the CPU time went
}

TEST_F(TrainingAttempts, AProcessThatTrainedNothingIsLeftOut) {
  // Killed during evaluation, the cell's rerun starts `maps train` on a finished run: it trains no step.
  write_provenance(Json::array({train_record("CPU A", 0, 20000), train_record("CPU B", 20000, 20000)}).dump());
  const Json attempts = training_attempts(dir_);
  ASSERT_EQ(attempts.size(), 1U);
  EXPECT_EQ(attempts[0]["cpu"], "CPU A");
}

TEST_F(TrainingAttempts, RecordsFromBeforeTheStartStepAreKeptAndOtherSubcommandsSkipped) {
  Json old = train_record("CPU A", 0, 20000);
  old.erase("start_step");
  write_provenance(Json::array({old, {{"subcommand", "transfer"}, {"cpu", "CPU C"}}, 17, {{"subcommand", 3}}}).dump());
  const Json attempts = training_attempts(dir_);
  ASSERT_EQ(attempts.size(), 1U);
  EXPECT_EQ(attempts[0]["cpu"], "CPU A");
  EXPECT_FALSE(attempts[0].contains("start_step"));
}

TEST_F(TrainingAttempts, ADamagedFileIsNamedNotThrown) {
  write_provenance("[{\"subcommand\": \"train\", \"cpu\": ");
  Json attempts;
  ASSERT_NO_THROW(attempts = training_attempts(dir_));
  ASSERT_EQ(attempts.size(), 1U);
  const std::string error = attempts[0].value("error", "");
  EXPECT_NE(error.find("unreadable"), std::string::npos) << error;
  EXPECT_NE(error.find("provenance.json"), std::string::npos) << error;

  write_provenance("{\"subcommand\": \"train\"}");
  attempts = training_attempts(dir_);
  ASSERT_EQ(attempts.size(), 1U);
  EXPECT_NE(attempts[0].value("error", "").find("not a JSON array"), std::string::npos) << attempts.dump();
}

}  // namespace
}  // namespace maps::experiments
