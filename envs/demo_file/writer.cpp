// Writing a demo file (format 2), atomically: a temporary file in the same folder, renamed over the destination.

#include <hdf5.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <system_error>
#include <utility>

#include "envs/demo_file.h"
#include "envs/demo_file/format.h"
#include "envs/demo_file/hdf5_helpers.h"

namespace maps::envs {
namespace {

namespace fs = std::filesystem;
using demo_file_detail::Handle;
using demo_file_detail::hdf5_error_detail;
using demo_file_detail::join_path;
using demo_file_detail::kFormatVersion;
using demo_file_detail::kInvalidId;
using demo_file_detail::kObsKey;
using demo_file_detail::QuietHdf5Errors;
using demo_file_detail::RowMatrixXd;

// robomimic's data attribute env_args (robomimic/utils/file_utils.py reads it with json.loads; its code reads the
// kind from "type", though its docs say "env_type"): 2 is its EnvType.GYM_TYPE, the nearest of its kinds; env_kwargs
// say which of this project's task sets made the file.
std::string robomimic_env_args(const DemoFile& f) {
  const nlohmann::json args = {
      {"env_name", "maps/" + f.task_set},
      {"type", 2},
      {"env_kwargs", {{"task_set", f.task_set}, {"task_names", f.task_names}, {"env_version", f.env_version}}}};
  return args.dump();
}

Handle check_id(hid_t id, Handle::Closer closer, const std::string& file, const std::string& object,
                const std::string& what) {
  if (id < 0) {
    const std::string detail = hdf5_error_detail();
    throw std::runtime_error("demo file '" + file + "': " + object + ": cannot " + what +
                             (detail.empty() ? "" : " (HDF5: " + detail + ")"));
  }
  return Handle(id, closer);
}

class Writer {
 public:
  // Messages name `file` (the destination); the data goes to `temporary`, renamed over it afterwards.
  Writer(std::string file, std::string temporary) : file_(std::move(file)), temporary_(std::move(temporary)) {}

  Handle create_file() {
    return check_id(H5Fcreate(temporary_.c_str(), H5F_ACC_EXCL, H5P_DEFAULT, H5P_DEFAULT), H5Fclose, file_, "/",
                    "create the temporary file '" + temporary_ + "'");
  }
  Handle create_group(hid_t parent, const std::string& parent_path, const std::string& name) {
    return check_id(H5Gcreate2(parent, name.c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose, file_,
                    join_path(parent_path, name), "create group");
  }

  void check(herr_t status, const std::string& object, const std::string& what) {
    if (status < 0) check_id(kInvalidId, nullptr, file_, object, what);
  }

  // A dataset of `dims` (row-major data) with the given file and memory types.
  void dataset(hid_t parent, const std::string& parent_path, const std::string& name, hid_t file_type, hid_t mem_type,
               const std::vector<hsize_t>& dims, const void* data) {
    const std::string path = join_path(parent_path, name);
    Handle space = check_id(H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr), H5Sclose, file_,
                            path, "create dataspace");
    Handle ds =
        check_id(H5Dcreate2(parent, name.c_str(), file_type, space.get(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
                 H5Dclose, file_, path, "create dataset");
    // A dataset with no elements has nothing to write (and `data` may be null).
    std::size_t n = 1;
    for (hsize_t d : dims) n *= d;
    if (n > 0) check(H5Dwrite(ds.get(), mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data), path, "write dataset");
  }

  void string_array_dataset(hid_t parent, const std::string& parent_path, const std::string& name,
                            const std::vector<std::string>& values) {
    // Fixed-length NUL-padded strings, as numpy's "S" dtype (robomimic's masks) are stored.
    std::size_t width = 1;
    for (const auto& v : values) width = std::max(width, v.size());
    std::string buffer(values.size() * width, '\0');
    for (std::size_t i = 0; i < values.size(); ++i) std::copy(values[i].begin(), values[i].end(), &buffer[i * width]);
    const std::string path = join_path(parent_path, name);
    Handle type = check_id(H5Tcopy(H5T_C_S1), H5Tclose, file_, path, "create string type");
    check(H5Tset_size(type.get(), width), path, "set string size");
    check(H5Tset_strpad(type.get(), H5T_STR_NULLPAD), path, "set string padding");
    dataset(parent, parent_path, name, type.get(), type.get(), {values.size()}, buffer.data());
  }

  void attribute(hid_t object, const std::string& path, const std::string& name, hid_t file_type, hid_t mem_type,
                 hid_t space, const void* data) {
    const std::string where = path + " attribute '" + name + "'";
    Handle attr = check_id(H5Acreate2(object, name.c_str(), file_type, space, H5P_DEFAULT, H5P_DEFAULT), H5Aclose,
                           file_, where, "create");
    check(H5Awrite(attr.get(), mem_type, data), where, "write");
  }

  Handle scalar_space(const std::string& path) {
    return check_id(H5Screate(H5S_SCALAR), H5Sclose, file_, path, "create dataspace");
  }

  Handle vlen_string_type(const std::string& path) {
    Handle type = check_id(H5Tcopy(H5T_C_S1), H5Tclose, file_, path, "create string type");
    check(H5Tset_size(type.get(), H5T_VARIABLE), path, "set string size");
    check(H5Tset_cset(type.get(), H5T_CSET_UTF8), path, "set string charset");
    return type;
  }

  // Variable-length UTF-8 scalar string: h5py reads it as str.
  void string_attr(hid_t object, const std::string& path, const std::string& name, const std::string& value) {
    Handle type = vlen_string_type(path);
    Handle space = scalar_space(path);
    const char* p = value.c_str();
    attribute(object, path, name, type.get(), type.get(), space.get(), &p);
  }

  void string_array_attr(hid_t object, const std::string& path, const std::string& name,
                         const std::vector<std::string>& values) {
    Handle type = vlen_string_type(path);
    const hsize_t n = values.size();
    Handle space = check_id(H5Screate_simple(1, &n, nullptr), H5Sclose, file_, path, "create dataspace");
    std::vector<const char*> pointers;
    for (const auto& v : values) pointers.push_back(v.c_str());
    attribute(object, path, name, type.get(), type.get(), space.get(), pointers.data());
  }

  void int64_attr(hid_t object, const std::string& path, const std::string& name, std::int64_t value) {
    Handle space = scalar_space(path);
    attribute(object, path, name, H5T_STD_I64LE, H5T_NATIVE_INT64, space.get(), &value);
  }
  void uint64_attr(hid_t object, const std::string& path, const std::string& name, std::uint64_t value) {
    Handle space = scalar_space(path);
    attribute(object, path, name, H5T_STD_U64LE, H5T_NATIVE_UINT64, space.get(), &value);
  }
  void uint8_attr(hid_t object, const std::string& path, const std::string& name, std::uint8_t value) {
    Handle space = scalar_space(path);
    attribute(object, path, name, H5T_STD_U8LE, H5T_NATIVE_UINT8, space.get(), &value);
  }
  void double_attr(hid_t object, const std::string& path, const std::string& name, double value) {
    Handle space = scalar_space(path);
    attribute(object, path, name, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, space.get(), &value);
  }

  void write(const DemoFile& f) {
    Handle file = create_file();
    {
      Handle data = create_group(file.get(), "", "data");
      write_data_attributes(data.get(), f);
      for (std::size_t i = 0; i < f.demos.size(); ++i) write_demo(data.get(), static_cast<int>(i), f.demos[i]);
    }
    write_masks(file.get(), f);
    check(H5Fflush(file.get(), H5F_SCOPE_GLOBAL), "/", "flush the file");
    check(file.close(), "/", "close the file");
  }

 private:
  // The file's metadata, as attributes of the group data.
  void write_data_attributes(hid_t data, const DemoFile& f) {
    int64_attr(data, "data", "format_version", kFormatVersion);
    string_attr(data, "data", "task_set", f.task_set);
    string_array_attr(data, "data", "task_names", f.task_names);
    string_attr(data, "data", "env_version", f.env_version);
    string_attr(data, "data", "creation_command", f.creation_command);
    string_attr(data, "data", "extra_json", f.extra_json);
    int64_attr(data, "data", "total", f.total_samples());
    int64_attr(data, "data", "num_demos", static_cast<std::int64_t>(f.demos.size()));
    string_attr(data, "data", "env_args", robomimic_env_args(f));
  }

  // data/demo_<index>: its arrays, then its attributes.
  void write_demo(hid_t data, int index, const Demonstration& d) {
    const std::string name = demo_name(index);
    const std::string path = "data/" + name;
    Handle group = create_group(data, "data", name);
    const hsize_t t = static_cast<hsize_t>(d.obs.rows());
    const RowMatrixXd obs = d.obs, actions = d.actions;
    RowMatrixXd next_obs_rows(obs.rows(), obs.cols());
    next_obs_rows.topRows(obs.rows() - 1) = obs.bottomRows(obs.rows() - 1);
    next_obs_rows.bottomRows(1) = d.final_obs.transpose();
    const RowMatrixXd& next_obs = next_obs_rows;
    for (const auto& [group_name, rows] : {std::pair{"obs", &obs}, std::pair{"next_obs", &next_obs}}) {
      Handle keys = create_group(group.get(), path, group_name);
      dataset(keys.get(), path + "/" + group_name, kObsKey, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE,
              {t, static_cast<hsize_t>(rows->cols())}, rows->data());
    }
    dataset(group.get(), path, "actions", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {t, static_cast<hsize_t>(actions.cols())},
            actions.data());
    dataset(group.get(), path, "rewards", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {t}, d.rewards.data());
    dataset(group.get(), path, "dones", H5T_STD_U8LE, H5T_NATIVE_UINT8, {t}, d.dones.data());
    string_attr(group.get(), path, "task", d.task);
    int64_attr(group.get(), path, "task_index", d.task_index);
    int64_attr(group.get(), path, "num_samples", d.num_samples());
    double_attr(group.get(), path, "return", d.episode_return);
    uint8_attr(group.get(), path, "success", d.success ? 1 : 0);
    uint64_attr(group.get(), path, "seed", d.seed);
    string_attr(group.get(), path, "episode_end", episode_end_name(d.end));
  }

  // mask/train and mask/valid: the demos' names.
  void write_masks(hid_t file, const DemoFile& f) {
    Handle mask = create_group(file, "", "mask");
    for (const auto& [name, indices] : {std::pair{"train", &f.train}, std::pair{"valid", &f.valid}}) {
      std::vector<std::string> names;
      for (int index : *indices) names.push_back(demo_name(index));
      string_array_dataset(mask.get(), "mask", name, names);
    }
  }

  std::string file_;
  std::string temporary_;
};

std::string temporary_path(const std::string& path) {
  static std::atomic<unsigned> counter{0};
  const fs::path p(path);
  // Appended piece by piece: GCC 12 warns (-Wstringop-overflow, a false positive) on "." + std::string here.
  std::string name = ".";
  name.append(p.filename().string()).append(".tmp.").append(std::to_string(::getpid()));
  name.append(".").append(std::to_string(counter++));
  return (p.parent_path() / name).string();
}

}  // namespace

void write_demo_file(const std::string& path, const DemoFile& file) {
  try {
    validate_demo_file(file);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument("write_demo_file '" + path + "': invalid input: " + e.what());
  }
  // Format 2 stores next_obs and how each episode ended, which format 1 files never recorded.
  for (std::size_t i = 0; i < file.demos.size(); ++i) {
    const Demonstration& d = file.demos[i];
    if (d.final_obs.size() == 0 || d.end == EpisodeEnd::kUnknown)
      throw std::invalid_argument(
          "write_demo_file '" + path + "': data/" + demo_name(static_cast<int>(i)) + " has no " +
          (d.final_obs.size() == 0 ? "final observation" : "episode end") + ", which format " +
          std::to_string(kFormatVersion) +
          " stores (a demo read from a format 1 file has neither): collect the demos "
          "again" +
          (file.creation_command.empty() ? std::string() : " with `" + file.creation_command + "`"));
  }
  const QuietHdf5Errors quiet;
  const std::string temporary = temporary_path(path);
  try {
    Writer(path, temporary).write(file);
    std::error_code ec;
    fs::rename(temporary, path, ec);
    if (ec)
      throw std::runtime_error("demo file '" + path + "': cannot rename '" + temporary + "' to it: " + ec.message());
  } catch (...) {
    std::error_code ignored;
    fs::remove(temporary, ignored);
    throw;
  }
}

}  // namespace maps::envs
