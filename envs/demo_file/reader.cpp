// Reading a demo file's layout, format 2 and the older format 1 (envs/demo_file.h), into a DemoFile: every group,
// dataset and attribute checked as it is read, then the whole validated. read_demo_file_in_process.

#include <hdf5.h>

#include <cmath>
#include <limits>
#include <map>
#include <new>
#include <nlohmann/json.hpp>
#include <set>
#include <stdexcept>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "envs/demo_file.h"
#include "envs/demo_file/format.h"
#include "envs/demo_file/hdf5_helpers.h"
#include "envs/demo_file/hdf5_reader.h"

namespace maps::envs {
namespace {

using demo_file_detail::first_non_finite;
using demo_file_detail::Handle;
using demo_file_detail::Hdf5Reader;
using demo_file_detail::kFormatVersion;
using demo_file_detail::kObsKey;
using demo_file_detail::QuietHdf5Errors;
using demo_file_detail::shape_string;

class DemoFileReader : private Hdf5Reader {
 public:
  explicit DemoFileReader(std::string file) : Hdf5Reader(std::move(file)) {}

  DemoFile read_file() const {
    Handle file = open_file();
    DemoFile f;
    Handle data = open_group(file.get(), "", "data");
    f.format_version = read_format_version(data.get());
    read_metadata(data.get(), &f);
    const std::int64_t total = int64_attr(data.get(), "data", "total");
    const std::int64_t num_demos = read_num_demos(data.get());
    const std::map<std::string, int> demos = check_demo_members(data.get(), num_demos);

    Eigen::Index obs_dim = -1, act_dim = -1;
    for (int i = 0; i < num_demos; ++i)
      f.demos.push_back(read_demo(data.get(), i, f.format_version, &obs_dim, &act_dim));
    if (f.total_samples() != total)
      fail("data", "attribute total is " + std::to_string(total) + " but the demos hold " +
                       std::to_string(f.total_samples()) + " steps");

    Handle mask = open_group(file.get(), "", "mask");
    f.train = read_mask(mask.get(), "train", demos);
    f.valid = read_mask(mask.get(), "valid", demos);
    try {
      validate_demo_file(f);
    } catch (const std::invalid_argument& e) {
      fail("", e.what());
    }
    return f;
  }

 private:
  // The datasets of one demo, opened and checked for rank and type; format 2's obs and next_obs groups with them.
  struct DemoDatasets {
    Handle obs_group, next_obs_group;  // format 2 only
    Dataset obs, actions, rewards, dones;
  };

  // ----- the group data -----

  std::int64_t read_format_version(hid_t data) const {
    const std::int64_t version = int64_attr(data, "data", "format_version");
    if (version < 1 || version > kFormatVersion)
      fail("data", "unsupported format_version " + std::to_string(version) + " (this reader knows 1 to " +
                       std::to_string(kFormatVersion) + ")");
    return version;
  }

  // data's attributes that the DemoFile keeps (f->format_version already read); format 2's env_args checked.
  void read_metadata(hid_t data, DemoFile* f) const {
    if (f->format_version >= 2) {
      const std::string env_args = string_attr(data, "data", "env_args");
      if (!nlohmann::json::accept(env_args))
        fail("data", "attribute env_args is not JSON (robomimic reads it as JSON)");
    }
    f->task_set = string_attr(data, "data", "task_set");
    f->task_names = string_array_attr(data, "data", "task_names", false);
    f->env_version = string_attr(data, "data", "env_version");
    f->creation_command = string_attr(data, "data", "creation_command");
    f->extra_json = string_attr(data, "data", "extra_json");
  }

  std::int64_t read_num_demos(hid_t data) const {
    const std::int64_t num_demos = int64_attr(data, "data", "num_demos");
    if (num_demos < 0 || num_demos > std::numeric_limits<int>::max())
      fail("data", "attribute num_demos is " + std::to_string(num_demos));
    return num_demos;
  }

  static herr_t collect_name(hid_t, const char* name, const H5L_info_t*, void* out) {
    static_cast<std::vector<std::string>*>(out)->emplace_back(name);
    return 0;
  }

  // Members of data: exactly demo_0 .. demo_<num_demos-1>. Returns each demo's index by its name.
  std::map<std::string, int> check_demo_members(hid_t data, std::int64_t num_demos) const {
    std::vector<std::string> members;
    hsize_t position = 0;
    check(H5Literate(data, H5_INDEX_NAME, H5_ITER_NATIVE, &position, collect_name, &members), "data", "list members");
    // Compared before anything is built per demo: a damaged num_demos (up to 2^31 - 1) would otherwise make the
    // reader spend minutes and gigabytes naming demos that are not there (found by fuzz/fuzz_demo_file.cpp).
    if (static_cast<std::size_t>(num_demos) > members.size()) {
      // Among demo_0 .. demo_<members> at least one is absent: name the first.
      const std::set<std::string> present(members.begin(), members.end());
      for (int i = 0;; ++i)
        if (!present.contains(demo_name(i)))
          fail("data/" + demo_name(i), "missing group (attribute num_demos is " + std::to_string(num_demos) +
                                           ", data holds " + std::to_string(members.size()) + " members)");
    }
    std::map<std::string, int> demos;
    for (int i = 0; i < num_demos; ++i) demos.emplace(demo_name(i), i);
    for (const std::string& m : members)
      if (!demos.contains(m))
        fail("data/" + m, "unexpected member: data holds only demo_0 .. demo_" + std::to_string(num_demos - 1) +
                              " (attribute num_demos is " + std::to_string(num_demos) + ")");
    return demos;
  }

  // ----- one demo: data/demo_<index> -----

  Demonstration read_demo(hid_t data, int index, std::int64_t version, Eigen::Index* obs_dim,
                          Eigen::Index* act_dim) const {
    const std::string name = demo_name(index);
    const std::string path = "data/" + name;
    Handle group = open_group(data, "data", name);
    Demonstration d;
    const DemoDatasets datasets = open_demo_datasets(group.get(), path, version);
    check_demo_shapes(datasets, obs_dim, act_dim);
    read_demo_attributes(group.get(), path, version, datasets.obs, &d);
    read_demo_arrays(datasets, path, version, &d);
    check_demo_finite(datasets, path, d);
    return d;
  }

  // Format 1 kept obs as one dataset; format 2 as robomimic's group of named arrays, with next_obs beside it.
  DemoDatasets open_demo_datasets(hid_t group, const std::string& path, std::int64_t version) const {
    DemoDatasets ds;
    if (version >= 2) {
      ds.obs_group = open_group(group, path, "obs");
      ds.next_obs_group = open_group(group, path, "next_obs");
    }
    ds.obs = version >= 2
                 ? open_dataset(ds.obs_group.get(), path + "/obs", kObsKey, 2, {H5T_FLOAT, H5T_INTEGER}, "numeric")
                 : open_dataset(group, path, "obs", 2, {H5T_FLOAT, H5T_INTEGER}, "numeric");
    ds.actions = open_dataset(group, path, "actions", 2, {H5T_FLOAT, H5T_INTEGER}, "numeric");
    ds.rewards = open_dataset(group, path, "rewards", 1, {H5T_FLOAT, H5T_INTEGER}, "numeric");
    ds.dones = open_dataset(group, path, "dones", 1, {H5T_INTEGER}, "integer (0/1)");
    return ds;
  }

  // One row per step in every array, and obs and action widths as in the first demo (*obs_dim, *act_dim: -1 before
  // it).
  void check_demo_shapes(const DemoDatasets& ds, Eigen::Index* obs_dim, Eigen::Index* act_dim) const {
    const hsize_t t = ds.obs.dims[0];
    if (t == 0) fail(ds.obs.path, "has no steps (shape " + shape_string(ds.obs.dims) + ")");
    for (const Dataset* other : {&ds.actions, &ds.rewards, &ds.dones})
      if (other->dims[0] != t)
        fail(other->path, "has " + std::to_string(other->dims[0]) + " rows (shape " + shape_string(other->dims) +
                              ") but " + ds.obs.path + " has " + std::to_string(t) + " (shape " +
                              shape_string(ds.obs.dims) + "); every array of a demo needs one row per step");
    check_width(ds.obs, obs_dim, "observation");
    check_width(ds.actions, act_dim, "action");
  }

  void check_width(const Dataset& ds, Eigen::Index* width, const char* what) const {
    const auto w = static_cast<Eigen::Index>(ds.dims[1]);
    if (w == 0) fail(ds.path, std::string("has zero ") + what + " size (shape " + shape_string(ds.dims) + ")");
    if (*width < 0) *width = w;
    if (w != *width)
      fail(ds.path, "has " + std::to_string(w) + " columns but data/demo_0's has " + std::to_string(*width) + " (" +
                        what + " size must be the same in every demo)");
  }

  void read_demo_attributes(hid_t group, const std::string& path, std::int64_t version, const Dataset& obs,
                            Demonstration* d) const {
    const hsize_t t = obs.dims[0];
    const std::int64_t num_samples = int64_attr(group, path, "num_samples");
    if (num_samples != static_cast<std::int64_t>(t))
      fail(path, "attribute num_samples is " + std::to_string(num_samples) + " but " + obs.path + " has " +
                     std::to_string(t) + " rows");
    d->task = string_attr(group, path, "task");
    d->task_index = int64_attr(group, path, "task_index");
    d->episode_return = double_attr(group, path, "return");
    const std::int64_t success = int64_attr(group, path, "success");
    if (success != 0 && success != 1) fail(path, "attribute success should be 0 or 1, got " + std::to_string(success));
    d->success = success == 1;
    d->seed = uint64_attr(group, path, "seed");
    if (version >= 2) d->end = read_episode_end(group, path);
  }

  EpisodeEnd read_episode_end(hid_t group, const std::string& path) const {
    const std::string end = string_attr(group, path, "episode_end");
    if (end == "terminated") return EpisodeEnd::kTerminated;
    if (end == "truncated") return EpisodeEnd::kTruncated;
    fail(path, "attribute episode_end should be 'terminated' or 'truncated', got '" + end + "'");
  }

  void read_demo_arrays(const DemoDatasets& ds, const std::string& path, std::int64_t version, Demonstration* d) const {
    const hsize_t t = ds.obs.dims[0];
    d->obs = read_matrix(ds.obs);
    if (version >= 2) d->final_obs = read_final_obs(ds, path, d->obs);
    d->actions = read_matrix(ds.actions);
    d->rewards.resize(static_cast<Eigen::Index>(t));
    read(ds.rewards, H5T_NATIVE_DOUBLE, d->rewards.data());
    d->dones.assign(t, 0);
    read(ds.dones, H5T_NATIVE_UINT8, d->dones.data());
  }

  // Format 2's next_obs/flat: obs one step on, then the final observation, which is returned.
  Eigen::VectorXd read_final_obs(const DemoDatasets& ds, const std::string& path, const Eigen::MatrixXd& obs) const {
    Dataset next_obs =
        open_dataset(ds.next_obs_group.get(), path + "/next_obs", kObsKey, 2, {H5T_FLOAT, H5T_INTEGER}, "numeric");
    if (next_obs.dims != ds.obs.dims)
      fail(next_obs.path, "has shape " + shape_string(next_obs.dims) + " but " + ds.obs.path + " has " +
                              shape_string(ds.obs.dims) + "; next_obs needs one row per step");
    const Eigen::MatrixXd next = read_matrix(next_obs);
    // next_obs repeats obs one step on; only its last row is new. A file where they disagree is not trusted.
    for (Eigen::Index r = 0; r + 1 < next.rows(); ++r)
      if (next.row(r) != obs.row(r + 1))
        fail(next_obs.path, "row " + std::to_string(r) + " differs from " + ds.obs.path + " row " +
                                std::to_string(r + 1) + " (next_obs must be obs one step on)");
    Eigen::VectorXd final_obs = next.bottomRows(1).transpose();
    if (!final_obs.allFinite()) fail(next_obs.path, "its last row holds a NaN or an infinite value");
    return final_obs;
  }

  void check_demo_finite(const DemoDatasets& ds, const std::string& path, const Demonstration& d) const {
    for (const auto& [dataset, m, vector] :
         {std::tuple{&ds.obs, &d.obs, false}, std::tuple{&ds.actions, &d.actions, false}})
      if (const std::string bad = first_non_finite(*m, vector); !bad.empty()) fail(dataset->path, bad);
    if (const std::string bad = first_non_finite(d.rewards, true); !bad.empty()) fail(ds.rewards.path, bad);
    if (!std::isfinite(d.episode_return)) fail(path, "attribute return is not finite");
  }

  // ----- the group mask -----

  std::vector<int> read_mask(hid_t mask, const std::string& name, const std::map<std::string, int>& demos) const {
    const std::string path = "mask/" + name;
    std::vector<int> indices;
    for (const std::string& demo : string_dataset(mask, "mask", name)) {
      const auto it = demos.find(demo);
      if (it == demos.end())
        fail(path, "names '" + demo + "', which is not a demo in data (" + std::to_string(demos.size()) +
                       " demos: demo_0 .. demo_" + std::to_string(static_cast<int>(demos.size()) - 1) + ")");
      indices.push_back(it->second);
    }
    return indices;
  }
};

}  // namespace

DemoFile read_demo_file_in_process(const std::string& path) {
  const QuietHdf5Errors quiet;
  try {
    return DemoFileReader(path).read_file();
  } catch (const std::bad_alloc&) {
    throw std::runtime_error("demo file '" + path + "': out of memory while reading it (a size in it is damaged?)");
  }
}

}  // namespace maps::envs
