#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

// Demonstration files: HDF5 in robomimic's layout (its SequenceDataset and scripts read them), with this
// project's metadata beside it. Format 2:
//
//   /data                      group; attributes format_version (int64, 2), total (sum of num_samples), env_args
//                              (JSON, robomimic's: env_name "maps/<set>", type 2, env_kwargs), task_set,
//                              task_names (1-d variable-length UTF-8 strings), env_version, creation_command,
//                              extra_json (a JSON object as a string), num_demos
//   /data/demo_<i>             group, i = 0 .. num_demos-1; attributes num_samples (int64), task, task_index
//                              (int64), return (float64), success (uint8 0/1), seed (uint64), episode_end
//                              ("terminated": a terminal state of the task; "truncated": the time limit)
//   /data/demo_<i>/obs/flat       float64 [T, obs_dim]  row t: the observation step t's action saw
//   /data/demo_<i>/next_obs/flat  float64 [T, obs_dim]  row t: the observation after step t (obs one row on,
//                                                      then the final observation)
//   /data/demo_<i>/actions     float64 [T, act_dim]
//   /data/demo_<i>/rewards     float64 [T]
//   /data/demo_<i>/dones       uint8   [T]            1 where the episode ended after step t
//   /mask/train, /mask/valid   1-d fixed-length (NUL-padded) byte strings naming demos ("demo_3")
//
// Format 1 (before 2026-11-25) had obs as one dataset /data/demo_<i>/obs, no next_obs, env_args or episode_end:
// it still reads (final_obs empty, end unknown), but cannot be written again as format 2.
// Writing is atomic (a temporary file in the same folder, then rename); reading validates every
// group, dataset, attribute and shape and throws a message naming the file and the object path.
namespace maps::envs {

// How an episode ended: in a terminal state of the task (MT10's success, a HalfCheetah episode abandoned as
// failed), or at the time limit (truncated). Format 1 files did not record it.
enum class EpisodeEnd { kUnknown, kTerminated, kTruncated };
const char* episode_end_name(EpisodeEnd end);  // "unknown", "terminated", "truncated"

// One episode of one task; row t of every array is step t.
struct Demonstration {
  std::string task;                 // e.g. "gravity/0.5"; equals DemoFile::task_names[task_index]
  std::int64_t task_index = 0;      // index within the file's task set (the one-hot task id)
  std::uint64_t seed = 0;           // the seed the episode's initial state was drawn with
  Eigen::MatrixXd obs;              // [T, obs_dim]
  Eigen::MatrixXd actions;          // [T, act_dim]
  Eigen::VectorXd rewards;          // [T]
  std::vector<std::uint8_t> dones;  // [T], each 0 or 1
  double episode_return = 0.0;      // stored as attribute "return"
  bool success = false;
  // The observation after the last step (the last row of next_obs); empty when read from a format 1 file.
  Eigen::VectorXd final_obs;
  EpisodeEnd end = EpisodeEnd::kUnknown;

  std::int64_t num_samples() const { return obs.rows(); }
};

struct DemoFile {
  std::string task_set;                 // e.g. "gravity"
  std::vector<std::string> task_names;  // the set's tasks, in task_index order
  std::string env_version;
  std::string creation_command;
  std::string extra_json = "{}";     // any further metadata; must be valid JSON
  std::vector<Demonstration> demos;  // demos[i] is stored as data/demo_<i>
  std::vector<int> train;            // indices into demos (mask/train)
  std::vector<int> valid;            // indices into demos (mask/valid)
  std::int64_t format_version = 2;   // the version it was read from; write_demo_file always writes the newest

  std::int64_t total_samples() const;
};

// "demo_<i>", the group name of demos[i] (as robomimic names them).
std::string demo_name(int i);

// Throws std::invalid_argument naming the demo (as data/demo_<i>) and what is inconsistent:
// empty demos, rows of actions/rewards/dones differing from obs, obs or action width differing
// across demos, non-finite values, dones other than 0/1, task_index out of range or task not
// matching task_names[task_index], duplicate task names, masks with out-of-range, repeated or
// overlapping indices, extra_json that is not valid JSON.
void validate_demo_file(const DemoFile& file);

// Validates (std::invalid_argument, nothing written), then writes atomically: a temporary file
// in the same folder, renamed over `path`; the temporary is removed on any error. HDF5 failures
// throw std::runtime_error naming the file and the object path.
void write_demo_file(const std::string& path, const DemoFile& file);

// Reads and validates; throws std::runtime_error naming the file and what is wrong: missing
// file, not an HDF5 file, truncated or damaged file, missing group/dataset/attribute (by path),
// wrong type, rank or shape, a mask naming a demo that does not exist, NaN or infinite data.
DemoFile read_demo_file(const std::string& path);

// read_demo_file's refusal of a file whose reading killed the child process that read it first: libhdf5 1.10.8
// crashes or aborts on some damaged files (docs/reliability.md). Its own type, so that tests and fuzzers can tell it
// from a refusal the reader made.
class DemoFileReaderDied : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// read_demo_file without the child process: a crash while reading is the caller's. For the fuzzer, which must see a
// crash of this project's reader as one.
DemoFile read_demo_file_in_process(const std::string& path);

// Split of n_demos demonstrations into (train, valid) index lists, each sorted ascending. Every
// index is in exactly one list; valid gets floor((1 - train_fraction) * n) demos (as robomimic's
// split_train_val_from_hdf5 does), clamped so that each list has at least one demo when
// n_demos >= 2 (n_demos == 1 gives train = {0}). Deterministic for the seed on every platform.
// train_fraction must be in (0, 1).
std::pair<std::vector<int>, std::vector<int>> split_train_valid(int n_demos, double train_fraction = 0.7,
                                                                std::uint64_t seed = 0);

}  // namespace maps::envs
