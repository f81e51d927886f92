// Demo files damaged at random (issue 41, item 6): bytes of a valid file changed, cut or repeated. HDF5 keeps no
// checksum of its data, so a changed value that is still valid can be read; what the reader must never accept is a
// file that breaks an invariant of the format, which this test checks apart from the reader.
#include <gtest/gtest.h>
#include <hdf5.h>

#include <cmath>
#include <iostream>
#include <random>
#include <set>
#include <string>

#include "envs/demo_file.h"
#include "tests/common/mutations.h"
#include "tests/common/temp_folder.h"

namespace maps::envs {
namespace {

class DemoFileProperty : public TempFolderTest {
 protected:
  DemoFileProperty() : TempFolderTest("maps_demo_file_property_") {}
};

DemoFile small_file() {
  DemoFile f;
  f.task_set = "gravity";
  f.task_names = {"gravity/0.5", "gravity/1.5"};
  f.env_version = "HalfCheetah maps-1 / MuJoCo 2.2.2";
  f.creation_command = "maps collect --set gravity --demos 2";
  std::mt19937_64 rng(7);
  std::normal_distribution<double> normal;
  for (int i = 0; i < 4; ++i) {
    Demonstration d;
    d.task_index = i % 2;
    d.task = f.task_names[static_cast<std::size_t>(d.task_index)];
    d.seed = 100 + static_cast<std::uint64_t>(i);
    const int steps = 5 + i;
    d.obs = Eigen::MatrixXd::NullaryExpr(steps, 3, [&] { return normal(rng); });
    d.actions = Eigen::MatrixXd::NullaryExpr(steps, 2, [&] { return normal(rng); });
    d.rewards = Eigen::VectorXd::NullaryExpr(steps, [&] { return normal(rng); });
    d.dones.assign(static_cast<std::size_t>(steps), 0);
    d.dones.back() = 1;
    d.episode_return = d.rewards.sum();
    d.final_obs = Eigen::VectorXd::Zero(3);
    d.end = EpisodeEnd::kTruncated;
    f.demos.push_back(std::move(d));
  }
  f.train = {0, 1};
  f.valid = {2, 3};
  return f;
}

// The format's invariants, checked here apart from the reader.
bool invariants_hold(const DemoFile& f, std::string& why) {
  auto fail = [&why](const std::string& what) {
    why = what;
    return false;
  };
  if (f.format_version != 1 && f.format_version != 2) return fail("format_version");
  if (f.demos.empty()) return fail("no demos");
  std::set<std::string> names(f.task_names.begin(), f.task_names.end());
  if (names.size() != f.task_names.size()) return fail("a task named twice");
  for (const Demonstration& d : f.demos) {
    const auto rows = d.obs.rows();
    if (rows == 0 || d.actions.rows() != rows || d.rewards.size() != rows ||
        static_cast<Eigen::Index>(d.dones.size()) != rows)
      return fail("rows differ within a demo");
    if (d.obs.cols() != f.demos[0].obs.cols() || d.actions.cols() != f.demos[0].actions.cols())
      return fail("widths differ across demos");
    if (f.format_version == 2 && d.final_obs.size() != d.obs.cols()) return fail("final_obs width");
    if (!d.obs.allFinite() || !d.actions.allFinite() || !d.rewards.allFinite()) return fail("a non-finite value");
    if (d.task_index < 0 || d.task_index >= static_cast<std::int64_t>(f.task_names.size()) ||
        d.task != f.task_names[static_cast<std::size_t>(d.task_index)])
      return fail("task and task_index disagree");
    for (std::uint8_t done : d.dones)
      if (done > 1) return fail("a done other than 0 or 1");
  }
  std::set<int> seen;
  for (const auto* mask : {&f.train, &f.valid})
    for (int i : *mask)
      if (i < 0 || i >= static_cast<int>(f.demos.size()) || !seen.insert(i).second) return fail("masks");
  return true;
}

TEST_F(DemoFileProperty, ADamagedFileIsRefusedOrReadWithEveryInvariantIntact) {
  const std::string good = path("good.h5");
  write_demo_file(good, small_file());
  const std::string original = testing::read_bytes(good);
  DemoFile read;
  int died = 0;
  const auto counts = testing::check_mutants(
      "demo file bytes", original, path("damaged.h5"), testing::property_cases(300),
      [&](std::mt19937_64& rng, std::string& how) { return testing::byte_mutant(original, rng, how); },
      [&](const std::string& p) {
        // Every HDF5 object the reader opened is closed again, whatever it found (a leaked one keeps the file open).
        struct NoLeak {
          std::string how;
          ~NoLeak() { EXPECT_EQ(H5Fget_obj_count(static_cast<hid_t>(H5F_OBJ_ALL), H5F_OBJ_ALL), 0) << how; }
        } no_leak{p};
        try {
          read = read_demo_file(p);
        } catch (const DemoFileReaderDied&) {
          ++died;  // a refusal, but counted apart: the reading child died (libhdf5), not a check of ours
          throw;
        }
      },
      [&](std::string& why) { return invariants_hold(read, why); });
  EXPECT_GT(counts.refused, 0);
  std::cout << "property demo file bytes: " << died << " of the refusals were the reading child's death\n";
}

}  // namespace
}  // namespace maps::envs
