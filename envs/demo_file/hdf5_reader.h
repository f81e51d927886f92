#pragma once

#include <hdf5.h>

#include <cstdint>
#include <initializer_list>
#include <string>
#include <utility>
#include <vector>

#include "envs/demo_file/format.h"
#include "envs/demo_file/hdf5_helpers.h"

// Checked reading of one HDF5 file for the demo file's reader (envs/demo_file/reader.cpp): every failure throws
// std::runtime_error "demo file '<file>': <object path>: <what>". Internal to envs/demo_file/.
namespace maps::envs::demo_file_detail {

// libhdf5 loads no filter plugin while one lives, whatever a file's pipeline or HDF5_PLUGIN_PATH says
// (io::check_self_contained refuses such a dataset by name; this keeps a read it misses from loading code). The
// state before is restored after: the Python module's host process may read its own files with plugins.
class PluginsOff {
 public:
  PluginsOff() {
    if (H5PLget_loading_state(&saved_) < 0) saved_ = H5PL_ALL_PLUGIN;
    H5PLset_loading_state(0);
  }
  ~PluginsOff() { H5PLset_loading_state(saved_); }
  PluginsOff(const PluginsOff&) = delete;
  PluginsOff& operator=(const PluginsOff&) = delete;

 private:
  unsigned saved_ = H5PL_ALL_PLUGIN;
};

class Hdf5Reader {
 public:
  explicit Hdf5Reader(std::string file) : file_(std::move(file)) {}

  [[noreturn]] void fail(const std::string& object, const std::string& what) const;
  // fail() with the most specific message on HDF5's error stack appended.
  [[noreturn]] void fail_hdf5(const std::string& object, const std::string& what) const;
  Handle check_id(hid_t id, Handle::Closer closer, const std::string& object, const std::string& what) const;
  void check(herr_t status, const std::string& object, const std::string& what) const;

  // The file, read-only, once it is known to be a regular file in HDF5 that holds all its data itself
  // (io::check_self_contained).
  Handle open_file() const;
  bool exists(hid_t parent, const std::string& parent_path, const std::string& name) const;
  Handle open_group(hid_t parent, const std::string& parent_path, const std::string& name) const;

  struct Dataset {
    Handle ds;
    std::string path;
    std::vector<hsize_t> dims;
    H5T_class_t type_class = H5T_NO_CLASS;
  };

  // Opens parent/name and checks its rank, its declared size (against the file's) and its type class.
  Dataset open_dataset(hid_t parent, const std::string& parent_path, const std::string& name, int rank,
                       std::initializer_list<H5T_class_t> classes, const char* type_description) const;
  void read(const Dataset& d, hid_t mem_type, void* buffer) const;
  RowMatrixXd read_matrix(const Dataset& d) const;

  // Single-valued attributes (integers; a float or an integer for double_attr).
  std::int64_t int64_attr(hid_t object, const std::string& path, const std::string& name) const;
  std::uint64_t uint64_attr(hid_t object, const std::string& path, const std::string& name) const;
  double double_attr(hid_t object, const std::string& path, const std::string& name) const;
  // String attributes: a single string (`scalar`) or a 1-d array, fixed or variable length.
  std::vector<std::string> string_array_attr(hid_t object, const std::string& path, const std::string& name,
                                             bool scalar) const;
  std::string string_attr(hid_t object, const std::string& path, const std::string& name) const;
  // A 1-d dataset of strings.
  std::vector<std::string> string_dataset(hid_t parent, const std::string& parent_path, const std::string& name) const;

 private:
  Handle open_attr(hid_t object, const std::string& path, const std::string& name) const;
  // Number of elements of an attribute's dataspace, with its rank.
  std::pair<int, hsize_t> attr_extent(hid_t attr, const std::string& where) const;
  template <typename T>
  T numeric_attr(hid_t object, const std::string& path, const std::string& name, hid_t mem_type,
                 bool allow_float) const;
  // Strings of an attribute or dataset, fixed or variable length. `n` elements.
  std::vector<std::string> read_strings(hid_t object, bool is_attr, hid_t file_type, hsize_t n,
                                        const std::string& where) const;

  PluginsOff plugins_off_;
  std::string file_;
};

}  // namespace maps::envs::demo_file_detail
