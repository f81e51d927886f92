// Demo files (HDF5): structure-aware. Byte-level damage mostly tests libhdf5's own parser, so each input is a
// recipe of edits applied with the HDF5 API to a valid small demo file (2 tasks, 3 demos): links and attributes
// removed, integer attributes rewritten (huge, negative, of another type), datasets replaced by others of another
// shape (including zero rows) or type, NaN and infinities written into the data, masks naming demos that do not
// exist, demo groups renamed and task names changed. The result must be read (and then loaded as a training
// dataset) or refused with an exception; never a crash, a hang or a leak.

#include <fcntl.h>
#include <hdf5.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <string>
#include <vector>

#include "envs/demo_file.h"
#include "maps/data/demo_dataset.h"

namespace {

// Reads the recipe a byte at a time; 0 once it is used up.
class Recipe {
 public:
  Recipe(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}
  bool done() const { return at_ >= size_; }
  std::uint8_t byte() { return done() ? 0 : data_[at_++]; }
  std::int64_t int64() {
    std::uint64_t v = 0;
    for (int i = 0; i < 8; ++i) v = (v << 8) | byte();
    return static_cast<std::int64_t>(v);
  }
  template <typename T>
  const T& pick(const std::vector<T>& options) {
    return options[byte() % options.size()];
  }

 private:
  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t at_ = 0;
};

const std::string& base_file() {
  static const std::string path = [] {
    maps::envs::DemoFile f;
    f.task_set = "gravity";
    f.task_names = {"gravity/0.5", "gravity/1.0"};
    f.env_version = "fuzz";
    f.creation_command = "fuzz_demo_file";
    for (int i = 0; i < 3; ++i) {
      maps::envs::Demonstration d;
      d.task_index = i % 2;
      d.task = f.task_names[static_cast<std::size_t>(d.task_index)];
      d.seed = static_cast<std::uint64_t>(i);
      const int rows = 4 + i;
      d.obs = Eigen::MatrixXd::Random(rows, 3);
      d.actions = Eigen::MatrixXd::Random(rows, 2);
      d.rewards = Eigen::VectorXd::Random(rows);
      d.dones.assign(static_cast<std::size_t>(rows), 0);
      d.dones.back() = 1;
      d.episode_return = d.rewards.sum();
      d.final_obs = Eigen::VectorXd::Random(3);
      d.end = i % 2 == 0 ? maps::envs::EpisodeEnd::kTruncated : maps::envs::EpisodeEnd::kTerminated;
      f.demos.push_back(d);
    }
    f.train = {0, 1};
    f.valid = {2};
    const std::string out =
        (std::filesystem::temp_directory_path() / ("maps-fuzz-base-" + std::to_string(::getpid()) + ".h5")).string();
    maps::envs::write_demo_file(out, f);
    return out;
  }();
  return path;
}

const std::vector<std::string> kGroups = {
    "/data", "/mask", "/data/demo_0", "/data/demo_1", "/data/demo_2", "/data/demo_0/obs", "/data/demo_1/next_obs"};
const std::vector<std::string> kDatasets = {
    "/data/demo_0/obs/flat", "/data/demo_0/actions",       "/data/demo_1/rewards", "/data/demo_1/dones",
    "/data/demo_2/obs/flat", "/data/demo_2/next_obs/flat", "/mask/train",          "/mask/valid"};
const std::vector<std::string> kIntAttributes = {"format_version", "total", "num_demos", "num_samples",
                                                 "task_index",     "seed",  "success"};

void remove_attribute_if_present(hid_t object, const char* name) {
  if (H5Aexists(object, name) > 0) H5Adelete(object, name);
}

void write_int64_attribute(hid_t object, const char* name, std::int64_t value, bool as_double) {
  remove_attribute_if_present(object, name);
  const hid_t space = H5Screate(H5S_SCALAR);
  const hid_t type = as_double ? H5T_NATIVE_DOUBLE : H5T_NATIVE_INT64;
  const hid_t attr = H5Acreate2(object, name, type, space, H5P_DEFAULT, H5P_DEFAULT);
  if (attr >= 0) {
    const double as_real = static_cast<double>(value);
    H5Awrite(attr, type, as_double ? static_cast<const void*>(&as_real) : static_cast<const void*>(&value));
    H5Aclose(attr);
  }
  H5Sclose(space);
}

void replace_dataset(hid_t file, const std::string& path, hsize_t rows, hsize_t cols, hid_t type, double fill) {
  H5Ldelete(file, path.c_str(), H5P_DEFAULT);
  const hsize_t dims[2] = {rows, cols};
  const hid_t space = H5Screate_simple(cols == 0 ? 1 : 2, dims, nullptr);
  const hid_t set = H5Dcreate2(file, path.c_str(), type, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  if (set >= 0) {
    std::vector<double> values(static_cast<std::size_t>(rows * (cols == 0 ? 1 : cols)), fill);
    if (!values.empty()) H5Dwrite(set, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, values.data());
    H5Dclose(set);
  }
  H5Sclose(space);
}

void write_strings(hid_t object, const std::string& path, const std::vector<std::string>& values, bool attribute) {
  const hid_t type = H5Tcopy(H5T_C_S1);
  std::size_t width = 1;
  for (const auto& v : values) width = std::max(width, v.size());
  H5Tset_size(type, width);
  std::vector<char> buffer(values.size() * width, '\0');
  for (std::size_t i = 0; i < values.size(); ++i)
    std::memcpy(buffer.data() + i * width, values[i].data(), values[i].size());
  const hsize_t n = values.size();
  const hid_t space = H5Screate_simple(1, &n, nullptr);
  if (attribute) {
    remove_attribute_if_present(object, path.c_str());
    const hid_t attr = H5Acreate2(object, path.c_str(), type, space, H5P_DEFAULT, H5P_DEFAULT);
    if (attr >= 0) {
      if (n > 0) H5Awrite(attr, type, buffer.data());
      H5Aclose(attr);
    }
  } else {
    H5Ldelete(object, path.c_str(), H5P_DEFAULT);
    const hid_t set = H5Dcreate2(object, path.c_str(), type, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    if (set >= 0) {
      if (n > 0) H5Dwrite(set, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, buffer.data());
      H5Dclose(set);
    }
  }
  H5Sclose(space);
  H5Tclose(type);
}

std::vector<std::string> fuzzed_names(Recipe& r) {
  const std::vector<std::string> words = {"demo_0",      "demo_1",      "demo_2", "demo_3", "demo_99",
                                          "demo_-1",     "demo_",       "",       "data",   "demo_01",
                                          "gravity/0.5", "gravity/1.0", "x"};
  std::vector<std::string> out(r.byte() % 5);
  for (auto& name : out) name = r.pick(words);
  return out;
}

void apply(hid_t file, Recipe& r) {
  switch (r.byte() % 10) {
    case 0:
      H5Ldelete(file, r.pick(r.byte() % 2 ? kGroups : kDatasets).c_str(), H5P_DEFAULT);
      break;
    case 1: {  // remove an attribute
      const hid_t object = H5Oopen(file, r.pick(kGroups).c_str(), H5P_DEFAULT);
      if (object >= 0) {
        remove_attribute_if_present(object, r.pick(kIntAttributes).c_str());
        H5Oclose(object);
      }
      break;
    }
    case 2: {  // an integer attribute rewritten: any value, sometimes as a double
      const hid_t object = H5Oopen(file, r.pick(kGroups).c_str(), H5P_DEFAULT);
      if (object >= 0) {
        const std::vector<std::int64_t> specials = {
            0, -1, 1, 3, 1LL << 40, std::numeric_limits<std::int64_t>::max(), std::numeric_limits<std::int64_t>::min()};
        const std::int64_t value = r.byte() % 2 ? r.pick(specials) : r.int64();
        write_int64_attribute(object, r.pick(kIntAttributes).c_str(), value, r.byte() % 4 == 0);
        H5Oclose(object);
      }
      break;
    }
    case 3: {  // a dataset of another shape (zero rows included)
      const std::string& path = r.pick(kDatasets);
      replace_dataset(file, path, r.byte() % 9, r.byte() % 5, H5T_IEEE_F64LE, 0.25);
      break;
    }
    case 4: {  // another type
      const std::vector<hid_t> types = {H5T_STD_I32LE, H5T_IEEE_F32LE, H5T_STD_U8LE, H5T_STD_I64LE};
      replace_dataset(file, r.pick(kDatasets), 4, r.byte() % 4, r.pick(types), 1.0);
      break;
    }
    case 5: {  // NaN or an infinity in the data
      const std::vector<double> bad = {std::nan(""), std::numeric_limits<double>::infinity(),
                                       -std::numeric_limits<double>::infinity(), 1e308};
      const std::vector<std::string> data_sets = {"/data/demo_0/obs/flat", "/data/demo_1/actions",
                                                  "/data/demo_2/rewards", "/data/demo_1/next_obs/flat"};
      const std::string& path = r.pick(data_sets);
      const hid_t set = H5Dopen2(file, path.c_str(), H5P_DEFAULT);
      if (set >= 0) {
        const hid_t space = H5Dget_space(set);
        const hsize_t one = 1, where[2] = {static_cast<hsize_t>(r.byte() % 4), 0};
        if (H5Sselect_elements(space, H5S_SELECT_SET, 1, where) >= 0) {
          const hid_t mem = H5Screate_simple(1, &one, nullptr);
          const double value = r.pick(bad);
          H5Dwrite(set, H5T_NATIVE_DOUBLE, mem, space, H5P_DEFAULT, &value);
          H5Sclose(mem);
        }
        H5Sclose(space);
        H5Dclose(set);
      }
      break;
    }
    case 6:  // masks naming any demo
      write_strings(file, r.byte() % 2 ? "/mask/train" : "/mask/valid", fuzzed_names(r), false);
      break;
    case 7: {  // a demo group moved to another name
      const std::vector<std::string> to = {"/data/demo_5", "/data/demo_3", "/data/x", "/mask/demo_0"};
      H5Lmove(file, r.pick(kGroups).c_str(), file, r.pick(to).c_str(), H5P_DEFAULT, H5P_DEFAULT);
      break;
    }
    case 8: {  // a format 2 string attribute rewritten: how an episode ended, robomimic's env_args
      const std::vector<std::string> values = {"terminated", "truncated", "", "{", "{}", "[1]", "null", "crashed"};
      const std::vector<std::string> demos = {"/data/demo_0", "/data/demo_2"};
      const bool env_args = r.byte() % 2 == 0;
      const hid_t object = H5Oopen(file, env_args ? "/data" : r.pick(demos).c_str(), H5P_DEFAULT);
      if (object >= 0) {
        write_strings(object, env_args ? "env_args" : "episode_end", {r.pick(values)}, true);
        H5Oclose(object);
      }
      break;
    }
    default: {  // task names changed
      const hid_t data = H5Gopen2(file, "/data", H5P_DEFAULT);
      if (data >= 0) {
        write_strings(data, "task_names", fuzzed_names(r), true);
        H5Gclose(data);
      }
      break;
    }
  }
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);  // the edits fail often by design; keep stderr quiet
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::string work =
      (std::filesystem::temp_directory_path() / ("maps-fuzz-demo-" + std::to_string(::getpid()) + ".h5")).string();
  // Written from memory with write(2) retried on EINTR: copy_file's sendfile was interrupted by libFuzzer's timer
  // signal and threw (a harness failure, not a reader's).
  static const std::string base = [] {
    std::ifstream in(base_file(), std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
  }();
  const int fd = ::open(work.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
  if (fd < 0) return 0;
  for (std::size_t done = 0; done < base.size();) {
    const ssize_t n = ::write(fd, base.data() + done, base.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    done += static_cast<std::size_t>(n);
  }
  ::close(fd);
  Recipe recipe(data, size);
  const hid_t file = H5Fopen(work.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
  if (file < 0) return 0;
  for (int edits = 0; edits < 8 && !recipe.done(); ++edits) apply(file, recipe);
  H5Fclose(file);
  try {
    const maps::envs::DemoFile read = maps::envs::read_demo_file_in_process(work);
    maps::core::DataConfig config;
    config.demos_per_task = 1;
    config.subsample = 1;
    const maps::core::DemoDataset dataset(read, config);
  } catch (const std::exception&) {
  }
  return 0;
}
