#pragma once

#include <hdf5.h>

#include <string>
#include <utility>
#include <vector>

// Small HDF5 helpers of the demo file's writer and reader. Internal to envs/demo_file/.
namespace maps::envs::demo_file_detail {

constexpr hid_t kInvalidId = -1;

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

// The most specific message on HDF5's error stack (then clears it); "" when there is none.
std::string hdf5_error_detail();

// Frees the strings HDF5 allocated when it read variable-length strings into `buffer`.
void reclaim_vlen(hid_t mem_type, hid_t space, void* buffer);

// "parent/name", or "name" at the root ("").
std::string join_path(const std::string& parent, const std::string& name);

// "[3, 39]".
std::string shape_string(const std::vector<hsize_t>& dims);

}  // namespace maps::envs::demo_file_detail
