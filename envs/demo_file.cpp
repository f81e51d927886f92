#include "envs/demo_file.h"

#include <hdf5.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <filesystem>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <stdexcept>
#include <system_error>
#include <tuple>
#include <utility>

#include "envs/portable_random.h"
#include "io/hdf5_self_contained.h"
#include "io/isolated.h"
#include "io/json_input.h"

namespace maps::envs {
namespace {

namespace fs = std::filesystem;

using RowMatrixXd = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

// 1: obs a dataset, no next_obs (2026-11 and before). 2: robomimic's layout: obs and next_obs groups of named
// arrays (one key, "flat"), data attribute env_args, per-demo episode_end.
constexpr std::int64_t kFormatVersion = 2;
constexpr const char* kObsKey = "flat";
constexpr hid_t kInvalidId = -1;
// Far above what reading a valid demo file takes: a bound only for a child that loops in libhdf5.
constexpr double kIsolatedReadSeconds = 300.0;

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

// ----- small HDF5 helpers -----

// Owns one hid_t and closes it with the matching H5?close.
class Handle {
 public:
  using Closer = herr_t (*)(hid_t);
  Handle() = default;
  Handle(hid_t id, Closer closer) : id_(id), closer_(closer) {}
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;
  Handle(Handle&& other) noexcept : id_(std::exchange(other.id_, kInvalidId)), closer_(other.closer_) {}
  Handle& operator=(Handle&& other) noexcept {
    if (this != &other) {
      close();
      id_ = std::exchange(other.id_, kInvalidId);
      closer_ = other.closer_;
    }
    return *this;
  }
  ~Handle() { close(); }

  hid_t get() const { return id_; }
  bool valid() const { return id_ >= 0; }
  // Closes now; returns the H5?close result (0 when there was nothing to close).
  herr_t close() {
    herr_t result = 0;
    if (id_ >= 0 && closer_ != nullptr) result = closer_(id_);
    id_ = kInvalidId;
    return result;
  }

 private:
  hid_t id_ = kInvalidId;
  Closer closer_ = nullptr;
};

// Turns HDF5's automatic error printing off for the scope and restores the previous handler.
class QuietHdf5Errors {
 public:
  QuietHdf5Errors() {
    H5Eget_auto2(H5E_DEFAULT, &func_, &data_);
    H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  }
  QuietHdf5Errors(const QuietHdf5Errors&) = delete;
  QuietHdf5Errors& operator=(const QuietHdf5Errors&) = delete;
  ~QuietHdf5Errors() { H5Eset_auto2(H5E_DEFAULT, func_, data_); }

 private:
  H5E_auto2_t func_ = nullptr;
  void* data_ = nullptr;
};

herr_t collect_error(unsigned n, const H5E_error2_t* err, void* out) {
  // Walked upward: the first entry is the most specific one, which says what happened.
  if (n == 0 && err->desc != nullptr) *static_cast<std::string*>(out) = err->desc;
  return 0;
}

// The most specific message on HDF5's error stack (then clears it); "" when there is none.
std::string hdf5_error_detail() {
  std::string detail;
  H5Ewalk2(H5E_DEFAULT, H5E_WALK_UPWARD, collect_error, &detail);
  H5Eclear2(H5E_DEFAULT);
  return detail;
}

void reclaim_vlen(hid_t mem_type, hid_t space, void* buffer) {
#if H5_VERSION_GE(1, 12, 0)
  H5Treclaim(mem_type, space, H5P_DEFAULT, buffer);
#else
  H5Dvlen_reclaim(mem_type, space, H5P_DEFAULT, buffer);
#endif
}

std::string join_path(const std::string& parent, const std::string& name) {
  return parent.empty() ? name : parent + "/" + name;
}

std::string shape_string(const std::vector<hsize_t>& dims) {
  std::string s = "[";
  for (std::size_t i = 0; i < dims.size(); ++i) s += (i ? ", " : "") + std::to_string(dims[i]);
  return s + "]";
}

// Where the first non-finite value of a matrix is, as "row r, column c" (or "" if all finite).
template <typename Derived>
std::string first_non_finite(const Eigen::DenseBase<Derived>& m, bool vector) {
  for (Eigen::Index r = 0; r < m.rows(); ++r)
    for (Eigen::Index c = 0; c < m.cols(); ++c)
      if (!std::isfinite(m(r, c))) {
        const std::string what = std::isnan(m(r, c)) ? "NaN" : "infinite value";
        return what + (vector ? " at step " + std::to_string(r)
                              : " at row " + std::to_string(r) + ", column " + std::to_string(c));
      }
  return "";
}

// ----- validation of the in-memory structure -----

[[noreturn]] void invalid(const std::string& what) { throw std::invalid_argument(what); }

void validate_mask(const std::vector<int>& mask, const std::string& name, std::size_t n_demos) {
  std::set<int> seen;
  for (int index : mask) {
    if (index < 0 || static_cast<std::size_t>(index) >= n_demos)
      invalid(name + " references demo " + std::to_string(index) + ", which does not exist (" +
              std::to_string(n_demos) + " demos)");
    if (!seen.insert(index).second) invalid(name + " lists " + demo_name(index) + " twice");
  }
}

// ----- writing -----

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
      int64_attr(data.get(), "data", "format_version", kFormatVersion);
      string_attr(data.get(), "data", "task_set", f.task_set);
      string_array_attr(data.get(), "data", "task_names", f.task_names);
      string_attr(data.get(), "data", "env_version", f.env_version);
      string_attr(data.get(), "data", "creation_command", f.creation_command);
      string_attr(data.get(), "data", "extra_json", f.extra_json);
      int64_attr(data.get(), "data", "total", f.total_samples());
      int64_attr(data.get(), "data", "num_demos", static_cast<std::int64_t>(f.demos.size()));
      string_attr(data.get(), "data", "env_args", robomimic_env_args(f));
      for (std::size_t i = 0; i < f.demos.size(); ++i) {
        const Demonstration& d = f.demos[i];
        const std::string name = demo_name(static_cast<int>(i));
        const std::string path = "data/" + name;
        Handle group = create_group(data.get(), "data", name);
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
        dataset(group.get(), path, "actions", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE,
                {t, static_cast<hsize_t>(actions.cols())}, actions.data());
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
    }
    {
      Handle mask = create_group(file.get(), "", "mask");
      for (const auto& [name, indices] : {std::pair{"train", &f.train}, std::pair{"valid", &f.valid}}) {
        std::vector<std::string> names;
        for (int index : *indices) names.push_back(demo_name(index));
        string_array_dataset(mask.get(), "mask", name, names);
      }
    }
    check(H5Fflush(file.get(), H5F_SCOPE_GLOBAL), "/", "flush the file");
    check(file.close(), "/", "close the file");
  }

 private:
  std::string file_;
  std::string temporary_;
};

// ----- reading -----

class Reader {
 public:
  explicit Reader(std::string file) : file_(std::move(file)) {}

  [[noreturn]] void fail(const std::string& object, const std::string& what) const {
    throw std::runtime_error("demo file '" + file_ + "': " + (object.empty() ? "" : object + ": ") + what);
  }
  [[noreturn]] void fail_hdf5(const std::string& object, const std::string& what) const {
    const std::string detail = hdf5_error_detail();
    fail(object, what + (detail.empty() ? "" : " (HDF5: " + detail + ")"));
  }
  Handle check_id(hid_t id, Handle::Closer closer, const std::string& object, const std::string& what) const {
    if (id < 0) fail_hdf5(object, "cannot " + what);
    return Handle(id, closer);
  }
  void check(herr_t status, const std::string& object, const std::string& what) const {
    if (status < 0) fail_hdf5(object, "cannot " + what);
  }

  Handle open_file() const {
    std::error_code ec;
    const fs::file_status status = fs::status(file_, ec);
    if (!fs::exists(status)) fail("", "no such file");
    if (!fs::is_regular_file(status)) fail("", "not a regular file");
#if H5_VERSION_GE(1, 12, 0)
    const htri_t is_hdf5 = H5Fis_accessible(file_.c_str(), H5P_DEFAULT);
#else
    const htri_t is_hdf5 = H5Fis_hdf5(file_.c_str());
#endif
    if (is_hdf5 <= 0) {
      hdf5_error_detail();  // clear
      fail("", "not an HDF5 file (no HDF5 signature; is the file empty or of another format?)");
    }
    const hid_t id = H5Fopen(file_.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
    if (id < 0) {
      const std::string detail = hdf5_error_detail();
      const bool truncated = detail.find("truncated") != std::string::npos;
      fail("", std::string("cannot open: ") + (truncated ? "the file is truncated" : "the file is damaged") +
                   (detail.empty() ? "" : " (HDF5: " + detail + ")"));
    }
    Handle file(id, H5Fclose);
    try {
      io::check_self_contained(id, file_);
    } catch (const std::runtime_error& e) {
      // "HDF5 file 'F': ..." -> "demo file 'F': ...": the file named once.
      std::string what = e.what();
      const std::string prefix = "HDF5 file '" + file_ + "': ";
      if (what.rfind(prefix, 0) == 0) what = what.substr(prefix.size());
      fail("", what);
    }
    return file;
  }

  bool exists(hid_t parent, const std::string& parent_path, const std::string& name) const {
    const htri_t e = H5Lexists(parent, name.c_str(), H5P_DEFAULT);
    if (e < 0) fail_hdf5(join_path(parent_path, name), "cannot look up");
    return e > 0;
  }

  Handle open_group(hid_t parent, const std::string& parent_path, const std::string& name) const {
    const std::string path = join_path(parent_path, name);
    if (!exists(parent, parent_path, name)) fail(path, "missing group");
    const hid_t id = H5Gopen2(parent, name.c_str(), H5P_DEFAULT);
    if (id < 0) fail_hdf5(path, "exists but cannot be opened as a group");
    return Handle(id, H5Gclose);
  }

  struct Dataset {
    Handle ds;
    std::string path;
    std::vector<hsize_t> dims;
    H5T_class_t type_class = H5T_NO_CLASS;
  };

  // Opens parent/name and checks its rank and type class.
  Dataset open_dataset(hid_t parent, const std::string& parent_path, const std::string& name, int rank,
                       std::initializer_list<H5T_class_t> classes, const char* type_description) const {
    Dataset d;
    d.path = join_path(parent_path, name);
    if (!exists(parent, parent_path, name)) fail(d.path, "missing dataset");
    const hid_t id = H5Dopen2(parent, name.c_str(), H5P_DEFAULT);
    if (id < 0) fail_hdf5(d.path, "exists but cannot be opened as a dataset");
    d.ds = Handle(id, H5Dclose);
    Handle space = check_id(H5Dget_space(id), H5Sclose, d.path, "get dataspace");
    const int ndims = H5Sget_simple_extent_ndims(space.get());
    if (ndims < 0) fail_hdf5(d.path, "cannot get rank");
    if (ndims != rank)
      fail(d.path, "expected a " + std::to_string(rank) + "-d dataset, found rank " + std::to_string(ndims));
    d.dims.assign(static_cast<std::size_t>(rank), 0);
    if (H5Sget_simple_extent_dims(space.get(), d.dims.data(), nullptr) < 0) fail_hdf5(d.path, "cannot get shape");
    // A damaged extent would have the reader allocate terabytes (std::bad_alloc after seconds of paging): what a
    // dataset declares must fit what a file of this size can hold, compressed 64-fold at most, or 64 MB.
    long double elements = 1;
    for (hsize_t x : d.dims) elements *= static_cast<long double>(x);
    std::error_code size_error;
    const std::uintmax_t size = fs::file_size(file_, size_error);
    const long double file_bytes = size_error ? 0.0L : static_cast<long double>(size);
    if (elements * 8 > std::max<long double>(64.0L * (1 << 20), 64.0L * file_bytes))
      fail(d.path, "declares " + shape_string(d.dims) + " elements, more than a file of " +
                       std::to_string(static_cast<unsigned long long>(file_bytes)) +
                       " bytes can hold (a damaged file?)");
    Handle type = check_id(H5Dget_type(id), H5Tclose, d.path, "get type");
    d.type_class = H5Tget_class(type.get());
    if (std::find(classes.begin(), classes.end(), d.type_class) == classes.end())
      fail(d.path, std::string("expected ") + type_description + " data");
    return d;
  }

  void read(const Dataset& d, hid_t mem_type, void* buffer) const {
    std::size_t n = 1;
    for (hsize_t x : d.dims) n *= x;
    if (n == 0) return;
    check(H5Dread(d.ds.get(), mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, buffer), d.path,
          "read data (truncated or damaged file?)");
  }

  RowMatrixXd read_matrix(const Dataset& d) const {
    RowMatrixXd m(static_cast<Eigen::Index>(d.dims[0]), static_cast<Eigen::Index>(d.dims[1]));
    read(d, H5T_NATIVE_DOUBLE, m.data());
    return m;
  }

  // ----- attributes -----

  Handle open_attr(hid_t object, const std::string& path, const std::string& name) const {
    const htri_t e = H5Aexists(object, name.c_str());
    if (e < 0) fail_hdf5(path, "cannot look up attribute '" + name + "'");
    if (e == 0) fail(path, "missing attribute '" + name + "'");
    return check_id(H5Aopen(object, name.c_str(), H5P_DEFAULT), H5Aclose, path, "open attribute '" + name + "'");
  }

  // Number of elements of an attribute's dataspace, with its rank.
  std::pair<int, hsize_t> attr_extent(hid_t attr, const std::string& where) const {
    Handle space = check_id(H5Aget_space(attr), H5Sclose, where, "get dataspace");
    const int ndims = H5Sget_simple_extent_ndims(space.get());
    const hssize_t n = H5Sget_simple_extent_npoints(space.get());
    if (ndims < 0 || n < 0) fail_hdf5(where, "cannot get shape");
    return {ndims, static_cast<hsize_t>(n)};
  }

  template <typename T>
  T numeric_attr(hid_t object, const std::string& path, const std::string& name, hid_t mem_type,
                 bool allow_float) const {
    Handle attr = open_attr(object, path, name);
    const std::string where = path + " attribute '" + name + "'";
    Handle type = check_id(H5Aget_type(attr.get()), H5Tclose, where, "get type");
    const H5T_class_t cls = H5Tget_class(type.get());
    if (!(cls == H5T_INTEGER || (allow_float && cls == H5T_FLOAT)))
      fail(path, "attribute '" + name + "' should be " + (allow_float ? "a number" : "an integer"));
    if (attr_extent(attr.get(), where).second != 1) fail(path, "attribute '" + name + "' should be a single value");
    T value{};
    check(H5Aread(attr.get(), mem_type, &value), where, "read");
    return value;
  }
  std::int64_t int64_attr(hid_t object, const std::string& path, const std::string& name) const {
    return numeric_attr<std::int64_t>(object, path, name, H5T_NATIVE_INT64, false);
  }
  std::uint64_t uint64_attr(hid_t object, const std::string& path, const std::string& name) const {
    return numeric_attr<std::uint64_t>(object, path, name, H5T_NATIVE_UINT64, false);
  }
  double double_attr(hid_t object, const std::string& path, const std::string& name) const {
    return numeric_attr<double>(object, path, name, H5T_NATIVE_DOUBLE, true);
  }

  // Strings of an attribute or dataset, fixed or variable length. `n` elements.
  std::vector<std::string> read_strings(hid_t object, bool is_attr, hid_t file_type, hsize_t n,
                                        const std::string& where) const {
    std::vector<std::string> out;
    if (n == 0) return out;
    auto do_read = [&](hid_t mem_type, void* buffer) {
      const herr_t status = is_attr ? H5Aread(object, mem_type, buffer)
                                    : H5Dread(object, mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, buffer);
      check(status, where, "read strings");
    };
    const htri_t variable = H5Tis_variable_str(file_type);
    if (variable < 0) fail_hdf5(where, "cannot inspect string type");
    if (variable > 0) {
      Handle mem = check_id(H5Tcopy(H5T_C_S1), H5Tclose, where, "create string type");
      check(H5Tset_size(mem.get(), H5T_VARIABLE), where, "set string size");
      check(H5Tset_cset(mem.get(), H5Tget_cset(file_type)), where, "set string charset");
      std::vector<char*> pointers(n, nullptr);
      do_read(mem.get(), pointers.data());
      for (char* p : pointers) out.emplace_back(p == nullptr ? "" : p);
      Handle space = check_id(H5Screate_simple(1, &n, nullptr), H5Sclose, where, "create dataspace");
      reclaim_vlen(mem.get(), space.get(), pointers.data());
    } else {
      const std::size_t width = H5Tget_size(file_type);
      if (width == 0) fail_hdf5(where, "cannot get string size");
      Handle mem = check_id(H5Tcopy(H5T_C_S1), H5Tclose, where, "create string type");
      check(H5Tset_size(mem.get(), width), where, "set string size");
      check(H5Tset_strpad(mem.get(), H5T_STR_NULLPAD), where, "set string padding");
      std::string buffer(n * width, '\0');
      do_read(mem.get(), buffer.data());
      for (hsize_t i = 0; i < n; ++i) {
        std::string s = buffer.substr(i * width, width);
        s.resize(std::min(s.size(), s.find('\0')));
        out.push_back(std::move(s));
      }
    }
    return out;
  }

  std::vector<std::string> string_array_attr(hid_t object, const std::string& path, const std::string& name,
                                             bool scalar) const {
    Handle attr = open_attr(object, path, name);
    const std::string where = path + " attribute '" + name + "'";
    Handle type = check_id(H5Aget_type(attr.get()), H5Tclose, where, "get type");
    if (H5Tget_class(type.get()) != H5T_STRING) fail(path, "attribute '" + name + "' should be a string");
    const auto [rank, n] = attr_extent(attr.get(), where);
    if (scalar && n != 1) fail(path, "attribute '" + name + "' should be a single string");
    if (!scalar && rank != 1) fail(path, "attribute '" + name + "' should be a 1-d array of strings");
    return read_strings(attr.get(), true, type.get(), n, where);
  }
  std::string string_attr(hid_t object, const std::string& path, const std::string& name) const {
    return string_array_attr(object, path, name, true).front();
  }

  std::vector<std::string> string_dataset(hid_t parent, const std::string& parent_path, const std::string& name) const {
    Dataset d = open_dataset(parent, parent_path, name, 1, {H5T_STRING}, "string");
    Handle type = check_id(H5Dget_type(d.ds.get()), H5Tclose, d.path, "get type");
    return read_strings(d.ds.get(), false, type.get(), d.dims[0], d.path);
  }

  // ----- the layout -----

  static herr_t collect_name(hid_t, const char* name, const H5L_info_t*, void* out) {
    static_cast<std::vector<std::string>*>(out)->emplace_back(name);
    return 0;
  }

  Demonstration read_demo(hid_t data, int index, std::int64_t version, Eigen::Index* obs_dim,
                          Eigen::Index* act_dim) const {
    const std::string name = demo_name(index);
    const std::string path = "data/" + name;
    Handle group = open_group(data, "data", name);
    Demonstration d;
    // Format 1 kept obs as one dataset; format 2 as robomimic's group of named arrays, with next_obs beside it.
    Handle obs_group, next_obs_group;
    if (version >= 2) {
      obs_group = open_group(group.get(), path, "obs");
      next_obs_group = open_group(group.get(), path, "next_obs");
    }
    Dataset obs = version >= 2
                      ? open_dataset(obs_group.get(), path + "/obs", kObsKey, 2, {H5T_FLOAT, H5T_INTEGER}, "numeric")
                      : open_dataset(group.get(), path, "obs", 2, {H5T_FLOAT, H5T_INTEGER}, "numeric");
    Dataset actions = open_dataset(group.get(), path, "actions", 2, {H5T_FLOAT, H5T_INTEGER}, "numeric");
    Dataset rewards = open_dataset(group.get(), path, "rewards", 1, {H5T_FLOAT, H5T_INTEGER}, "numeric");
    Dataset dones = open_dataset(group.get(), path, "dones", 1, {H5T_INTEGER}, "integer (0/1)");
    const hsize_t t = obs.dims[0];
    if (t == 0) fail(obs.path, "has no steps (shape " + shape_string(obs.dims) + ")");
    for (const Dataset* other : {&actions, &rewards, &dones})
      if (other->dims[0] != t)
        fail(other->path, "has " + std::to_string(other->dims[0]) + " rows (shape " + shape_string(other->dims) +
                              ") but " + obs.path + " has " + std::to_string(t) + " (shape " + shape_string(obs.dims) +
                              "); every array of a demo needs one row per step");
    const auto check_width = [&](const Dataset& ds, Eigen::Index* width, const char* what) {
      const auto w = static_cast<Eigen::Index>(ds.dims[1]);
      if (w == 0) fail(ds.path, std::string("has zero ") + what + " size (shape " + shape_string(ds.dims) + ")");
      if (*width < 0) *width = w;
      if (w != *width)
        fail(ds.path, "has " + std::to_string(w) + " columns but data/demo_0's has " + std::to_string(*width) + " (" +
                          what + " size must be the same in every demo)");
    };
    check_width(obs, obs_dim, "observation");
    check_width(actions, act_dim, "action");

    const std::int64_t num_samples = int64_attr(group.get(), path, "num_samples");
    if (num_samples != static_cast<std::int64_t>(t))
      fail(path, "attribute num_samples is " + std::to_string(num_samples) + " but " + obs.path + " has " +
                     std::to_string(t) + " rows");
    d.task = string_attr(group.get(), path, "task");
    d.task_index = int64_attr(group.get(), path, "task_index");
    d.episode_return = double_attr(group.get(), path, "return");
    const std::int64_t success = int64_attr(group.get(), path, "success");
    if (success != 0 && success != 1) fail(path, "attribute success should be 0 or 1, got " + std::to_string(success));
    d.success = success == 1;
    d.seed = uint64_attr(group.get(), path, "seed");
    if (version >= 2) {
      const std::string end = string_attr(group.get(), path, "episode_end");
      if (end == "terminated")
        d.end = EpisodeEnd::kTerminated;
      else if (end == "truncated")
        d.end = EpisodeEnd::kTruncated;
      else
        fail(path, "attribute episode_end should be 'terminated' or 'truncated', got '" + end + "'");
    }

    d.obs = read_matrix(obs);
    if (version >= 2) {
      Dataset next_obs =
          open_dataset(next_obs_group.get(), path + "/next_obs", kObsKey, 2, {H5T_FLOAT, H5T_INTEGER}, "numeric");
      if (next_obs.dims != obs.dims)
        fail(next_obs.path, "has shape " + shape_string(next_obs.dims) + " but " + obs.path + " has " +
                                shape_string(obs.dims) + "; next_obs needs one row per step");
      const Eigen::MatrixXd next = read_matrix(next_obs);
      // next_obs repeats obs one step on; only its last row is new. A file where they disagree is not trusted.
      for (Eigen::Index r = 0; r + 1 < next.rows(); ++r)
        if (next.row(r) != d.obs.row(r + 1))
          fail(next_obs.path, "row " + std::to_string(r) + " differs from " + obs.path + " row " +
                                  std::to_string(r + 1) + " (next_obs must be obs one step on)");
      d.final_obs = next.bottomRows(1).transpose();
      if (!d.final_obs.allFinite()) fail(next_obs.path, "its last row holds a NaN or an infinite value");
    }
    d.actions = read_matrix(actions);
    d.rewards.resize(static_cast<Eigen::Index>(t));
    read(rewards, H5T_NATIVE_DOUBLE, d.rewards.data());
    d.dones.assign(t, 0);
    read(dones, H5T_NATIVE_UINT8, d.dones.data());
    for (const auto& [ds, m, vector] : {std::tuple{&obs, &d.obs, false}, std::tuple{&actions, &d.actions, false}})
      if (const std::string bad = first_non_finite(*m, vector); !bad.empty()) fail(ds->path, bad);
    if (const std::string bad = first_non_finite(d.rewards, true); !bad.empty()) fail(rewards.path, bad);
    if (!std::isfinite(d.episode_return)) fail(path, "attribute return is not finite");
    return d;
  }

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

  DemoFile read() const {
    Handle file = open_file();
    DemoFile f;
    Handle data = open_group(file.get(), "", "data");
    const std::int64_t version = int64_attr(data.get(), "data", "format_version");
    if (version < 1 || version > kFormatVersion)
      fail("data", "unsupported format_version " + std::to_string(version) + " (this reader knows 1 to " +
                       std::to_string(kFormatVersion) + ")");
    f.format_version = version;
    if (version >= 2) {
      const std::string env_args = string_attr(data.get(), "data", "env_args");
      if (!nlohmann::json::accept(env_args))
        fail("data", "attribute env_args is not JSON (robomimic reads it as JSON)");
    }
    f.task_set = string_attr(data.get(), "data", "task_set");
    f.task_names = string_array_attr(data.get(), "data", "task_names", false);
    f.env_version = string_attr(data.get(), "data", "env_version");
    f.creation_command = string_attr(data.get(), "data", "creation_command");
    f.extra_json = string_attr(data.get(), "data", "extra_json");
    const std::int64_t total = int64_attr(data.get(), "data", "total");
    const std::int64_t num_demos = int64_attr(data.get(), "data", "num_demos");
    if (num_demos < 0 || num_demos > std::numeric_limits<int>::max())
      fail("data", "attribute num_demos is " + std::to_string(num_demos));

    // Members of data: exactly demo_0 .. demo_<num_demos-1>.
    std::vector<std::string> members;
    hsize_t position = 0;
    check(H5Literate(data.get(), H5_INDEX_NAME, H5_ITER_NATIVE, &position, collect_name, &members), "data",
          "list members");
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

    Eigen::Index obs_dim = -1, act_dim = -1;
    for (int i = 0; i < num_demos; ++i) f.demos.push_back(read_demo(data.get(), i, version, &obs_dim, &act_dim));
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
  std::string file_;
};

std::string temporary_path(const std::string& path) {
  static std::atomic<unsigned> counter{0};
  const fs::path p(path);
  const std::string name =
      "." + p.filename().string() + ".tmp." + std::to_string(::getpid()) + "." + std::to_string(counter++);
  return (p.parent_path() / name).string();
}

}  // namespace

std::int64_t DemoFile::total_samples() const {
  std::int64_t total = 0;
  for (const auto& d : demos) total += d.num_samples();
  return total;
}

std::string demo_name(int i) { return "demo_" + std::to_string(i); }

const char* episode_end_name(EpisodeEnd end) {
  switch (end) {
    case EpisodeEnd::kTerminated:
      return "terminated";
    case EpisodeEnd::kTruncated:
      return "truncated";
    case EpisodeEnd::kUnknown:
      break;
  }
  return "unknown";
}

void validate_demo_file(const DemoFile& f) {
  std::set<std::string> names;
  for (const auto& name : f.task_names) {
    if (name.empty()) invalid("task_names holds an empty name");
    if (!names.insert(name).second) invalid("task_names lists '" + name + "' twice");
  }
  try {
    io::parse_json(f.extra_json, "extra_json");
  } catch (const std::runtime_error& e) {
    invalid(e.what());
  }
  Eigen::Index obs_dim = -1, act_dim = -1;
  for (std::size_t i = 0; i < f.demos.size(); ++i) {
    const Demonstration& d = f.demos[i];
    const std::string path = "data/" + demo_name(static_cast<int>(i));
    const Eigen::Index t = d.obs.rows();
    if (t == 0) invalid(path + ": has no steps (obs has 0 rows)");
    if (d.obs.cols() == 0) invalid(path + ": obs has 0 columns");
    if (d.actions.cols() == 0) invalid(path + ": actions has 0 columns");
    if (d.actions.rows() != t)
      invalid(path + ": actions has " + std::to_string(d.actions.rows()) + " rows but obs has " + std::to_string(t));
    if (d.rewards.size() != t)
      invalid(path + ": rewards has " + std::to_string(d.rewards.size()) + " entries but obs has " + std::to_string(t) +
              " rows");
    if (static_cast<Eigen::Index>(d.dones.size()) != t)
      invalid(path + ": dones has " + std::to_string(d.dones.size()) + " entries but obs has " + std::to_string(t) +
              " rows");
    if (obs_dim < 0) obs_dim = d.obs.cols(), act_dim = d.actions.cols();
    if (d.obs.cols() != obs_dim)
      invalid(path + ": obs has " + std::to_string(d.obs.cols()) + " columns but data/demo_0's has " +
              std::to_string(obs_dim) + " (observation size must be the same in every demo)");
    if (d.actions.cols() != act_dim)
      invalid(path + ": actions has " + std::to_string(d.actions.cols()) + " columns but data/demo_0's has " +
              std::to_string(act_dim) + " (action size must be the same in every demo)");
    if (auto bad = first_non_finite(d.obs, false); !bad.empty()) invalid(path + "/obs: " + bad);
    if (auto bad = first_non_finite(d.actions, false); !bad.empty()) invalid(path + "/actions: " + bad);
    if (auto bad = first_non_finite(d.rewards, true); !bad.empty()) invalid(path + "/rewards: " + bad);
    for (std::size_t s = 0; s < d.dones.size(); ++s)
      if (d.dones[s] > 1)
        invalid(path + "/dones: value " + std::to_string(d.dones[s]) + " at step " + std::to_string(s) +
                " (must be 0 or 1)");
    if (!std::isfinite(d.episode_return)) invalid(path + ": return is not finite");
    if (d.final_obs.size() != 0 && d.final_obs.size() != d.obs.cols())
      invalid(path + ": final_obs has " + std::to_string(d.final_obs.size()) + " entries but obs has " +
              std::to_string(d.obs.cols()) + " columns");
    if (!d.final_obs.allFinite()) invalid(path + ": final_obs holds a NaN or an infinite value");
    if (d.task_index < 0 || d.task_index >= static_cast<std::int64_t>(f.task_names.size()))
      invalid(path + ": task_index " + std::to_string(d.task_index) + " is out of range (" +
              std::to_string(f.task_names.size()) + " task names)");
    if (d.task != f.task_names[static_cast<std::size_t>(d.task_index)])
      invalid(path + ": task '" + d.task + "' differs from task_names[" + std::to_string(d.task_index) + "] = '" +
              f.task_names[static_cast<std::size_t>(d.task_index)] + "'");
  }
  validate_mask(f.train, "mask/train", f.demos.size());
  validate_mask(f.valid, "mask/valid", f.demos.size());
  const std::set<int> train(f.train.begin(), f.train.end());
  for (int index : f.valid)
    if (train.contains(index)) invalid(demo_name(index) + " is in both mask/train and mask/valid");
}

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

DemoFile read_demo_file_in_process(const std::string& path) {
  const QuietHdf5Errors quiet;
  try {
    return Reader(path).read();
  } catch (const std::bad_alloc&) {
    throw std::runtime_error("demo file '" + path + "': out of memory while reading it (a size in it is damaged?)");
  }
}

DemoFile read_demo_file(const std::string& path) {
  // libhdf5 1.10 can crash on a damaged file (a buffer overflow in H5HG_read, reading a variable-length string whose
  // global heap entry is damaged: found by the property test, DemoFileProperty) or loop in it. So the file is read
  // first by a child process; its death or hang is a refusal. A file the child read or refused is read here again,
  // which returns it or throws the child's error.
  const io::IsolatedOutcome probe =
      io::run_isolated([&path] { read_demo_file_in_process(path); }, kIsolatedReadSeconds);
  if (!probe.finished) {
    const std::string how =
        probe.timed_out ? "reading it took more than " + std::to_string(static_cast<int>(kIsolatedReadSeconds)) + " s"
        : probe.signal != 0 ? "reading it killed the process (signal " + std::to_string(probe.signal) + ")"
        : probe.exit_status != 0
            ? "reading it ended the process (exit status " + std::to_string(probe.exit_status) + ")"
            : "the process reading it died";
    throw DemoFileReaderDied("demo file '" + path + "': " + how + ": the file is damaged (libhdf5 " +
                             std::to_string(H5_VERS_MAJOR) + "." + std::to_string(H5_VERS_MINOR) + "." +
                             std::to_string(H5_VERS_RELEASE) + " crashes on some damaged files)");
  }
  return read_demo_file_in_process(path);
}

std::pair<std::vector<int>, std::vector<int>> split_train_valid(int n_demos, double train_fraction,
                                                                std::uint64_t seed) {
  if (n_demos < 0)
    throw std::invalid_argument("split_train_valid: n_demos must be >= 0, got " + std::to_string(n_demos));
  if (!(train_fraction > 0.0 && train_fraction < 1.0))
    throw std::invalid_argument("split_train_valid: train_fraction must be in (0, 1), got " +
                                std::to_string(train_fraction));
  // floor((1 - fraction) * n), with a little slack so that 0.3 * 10 = 3.0000000000000004 gives 3.
  int n_valid = static_cast<int>(std::floor((1.0 - train_fraction) * n_demos + 1e-9));
  if (n_demos >= 2) n_valid = std::clamp(n_valid, 1, n_demos - 1);
  if (n_demos < 2) n_valid = 0;

  // Fisher-Yates with splitmix64 and rejection sampling: the same permutation on every platform
  // (std::shuffle and std::uniform_int_distribution are implementation-defined).
  envs::SplitMix64 gen{seed};
  std::vector<int> order(static_cast<std::size_t>(n_demos));
  for (int i = 0; i < n_demos; ++i) order[static_cast<std::size_t>(i)] = i;
  for (int i = n_demos - 1; i > 0; --i) {
    const std::uint64_t r = draw_below(gen, static_cast<std::uint64_t>(i) + 1);
    std::swap(order[static_cast<std::size_t>(i)], order[static_cast<std::size_t>(r)]);
  }
  std::vector<int> valid(order.begin(), order.begin() + n_valid), train(order.begin() + n_valid, order.end());
  std::sort(train.begin(), train.end());
  std::sort(valid.begin(), valid.end());
  return {std::move(train), std::move(valid)};
}

}  // namespace maps::envs
