#include "envs/demo_file/hdf5_reader.h"

#include <algorithm>
#include <filesystem>
#include <stdexcept>
#include <system_error>

#include "io/hdf5_self_contained.h"

namespace maps::envs::demo_file_detail {

namespace fs = std::filesystem;

void Hdf5Reader::fail(const std::string& object, const std::string& what) const {
  throw std::runtime_error("demo file '" + file_ + "': " + (object.empty() ? "" : object + ": ") + what);
}
void Hdf5Reader::fail_hdf5(const std::string& object, const std::string& what) const {
  const std::string detail = hdf5_error_detail();
  fail(object, what + (detail.empty() ? "" : " (HDF5: " + detail + ")"));
}
Handle Hdf5Reader::check_id(hid_t id, Handle::Closer closer, const std::string& object, const std::string& what) const {
  if (id < 0) fail_hdf5(object, "cannot " + what);
  return Handle(id, closer);
}
void Hdf5Reader::check(herr_t status, const std::string& object, const std::string& what) const {
  if (status < 0) fail_hdf5(object, "cannot " + what);
}

Handle Hdf5Reader::open_file() const {
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

bool Hdf5Reader::exists(hid_t parent, const std::string& parent_path, const std::string& name) const {
  const htri_t e = H5Lexists(parent, name.c_str(), H5P_DEFAULT);
  if (e < 0) fail_hdf5(join_path(parent_path, name), "cannot look up");
  return e > 0;
}

Handle Hdf5Reader::open_group(hid_t parent, const std::string& parent_path, const std::string& name) const {
  const std::string path = join_path(parent_path, name);
  if (!exists(parent, parent_path, name)) fail(path, "missing group");
  const hid_t id = H5Gopen2(parent, name.c_str(), H5P_DEFAULT);
  if (id < 0) fail_hdf5(path, "exists but cannot be opened as a group");
  return Handle(id, H5Gclose);
}

Hdf5Reader::Dataset Hdf5Reader::open_dataset(hid_t parent, const std::string& parent_path, const std::string& name,
                                             int rank, std::initializer_list<H5T_class_t> classes,
                                             const char* type_description) const {
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
                     std::to_string(static_cast<unsigned long long>(file_bytes)) + " bytes can hold (a damaged file?)");
  Handle type = check_id(H5Dget_type(id), H5Tclose, d.path, "get type");
  d.type_class = H5Tget_class(type.get());
  if (std::find(classes.begin(), classes.end(), d.type_class) == classes.end())
    fail(d.path, std::string("expected ") + type_description + " data");
  return d;
}

void Hdf5Reader::read(const Dataset& d, hid_t mem_type, void* buffer) const {
  std::size_t n = 1;
  for (hsize_t x : d.dims) n *= x;
  if (n == 0) return;
  check(H5Dread(d.ds.get(), mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, buffer), d.path,
        "read data (truncated or damaged file?)");
}

RowMatrixXd Hdf5Reader::read_matrix(const Dataset& d) const {
  RowMatrixXd m(static_cast<Eigen::Index>(d.dims[0]), static_cast<Eigen::Index>(d.dims[1]));
  read(d, H5T_NATIVE_DOUBLE, m.data());
  return m;
}

Handle Hdf5Reader::open_attr(hid_t object, const std::string& path, const std::string& name) const {
  const htri_t e = H5Aexists(object, name.c_str());
  if (e < 0) fail_hdf5(path, "cannot look up attribute '" + name + "'");
  if (e == 0) fail(path, "missing attribute '" + name + "'");
  return check_id(H5Aopen(object, name.c_str(), H5P_DEFAULT), H5Aclose, path, "open attribute '" + name + "'");
}

std::pair<int, hsize_t> Hdf5Reader::attr_extent(hid_t attr, const std::string& where) const {
  Handle space = check_id(H5Aget_space(attr), H5Sclose, where, "get dataspace");
  const int ndims = H5Sget_simple_extent_ndims(space.get());
  const hssize_t n = H5Sget_simple_extent_npoints(space.get());
  if (ndims < 0 || n < 0) fail_hdf5(where, "cannot get shape");
  return {ndims, static_cast<hsize_t>(n)};
}

template <typename T>
T Hdf5Reader::numeric_attr(hid_t object, const std::string& path, const std::string& name, hid_t mem_type,
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
std::int64_t Hdf5Reader::int64_attr(hid_t object, const std::string& path, const std::string& name) const {
  return numeric_attr<std::int64_t>(object, path, name, H5T_NATIVE_INT64, false);
}
std::uint64_t Hdf5Reader::uint64_attr(hid_t object, const std::string& path, const std::string& name) const {
  return numeric_attr<std::uint64_t>(object, path, name, H5T_NATIVE_UINT64, false);
}
double Hdf5Reader::double_attr(hid_t object, const std::string& path, const std::string& name) const {
  return numeric_attr<double>(object, path, name, H5T_NATIVE_DOUBLE, true);
}

std::vector<std::string> Hdf5Reader::read_strings(hid_t object, bool is_attr, hid_t file_type, hsize_t n,
                                                  const std::string& where) const {
  std::vector<std::string> out;
  if (n == 0) return out;
  auto do_read = [&](hid_t mem_type, void* buffer) {
    const herr_t status =
        is_attr ? H5Aread(object, mem_type, buffer) : H5Dread(object, mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, buffer);
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

std::vector<std::string> Hdf5Reader::string_array_attr(hid_t object, const std::string& path, const std::string& name,
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
std::string Hdf5Reader::string_attr(hid_t object, const std::string& path, const std::string& name) const {
  return string_array_attr(object, path, name, true).front();
}

std::vector<std::string> Hdf5Reader::string_dataset(hid_t parent, const std::string& parent_path,
                                                    const std::string& name) const {
  Dataset d = open_dataset(parent, parent_path, name, 1, {H5T_STRING}, "string");
  Handle type = check_id(H5Dget_type(d.ds.get()), H5Tclose, d.path, "get type");
  return read_strings(d.ds.get(), false, type.get(), d.dims[0], d.path);
}
}  // namespace maps::envs::demo_file_detail
