#include "io/hdf5_self_contained.h"

#include <set>
#include <stdexcept>
#include <string>
#include <vector>

namespace maps::io {
namespace {

constexpr const char* kWhy =
    ": this tool reads a file from itself alone (no external links, external raw storage, virtual datasets or "
    "user-defined links)";

struct Walk {
  hid_t lapl = H5I_INVALID_HID;  // refuses to traverse external links
  std::set<std::string> groups;  // the groups seen, by address
  std::string error;             // the first refusal; the walk stops there
};

// The callback of H5Pset_elink_cb: an external link is never traversed while checking, whatever the link.
herr_t refuse_external_traversal(const char*, const char*, const char*, const char*, unsigned*, hid_t, void*) {
  return -1;
}

// An object's address in the file, as a string (HDF5 1.12 named it a token). H5Oget_info_by_name2 needs HDF5 1.10.3
// or later (Debian 12 has 1.10.8).
std::string object_key(hid_t group, const char* name, hid_t lapl, H5O_type_t& type) {
#if H5_VERSION_GE(1, 12, 0)
  H5O_info2_t info;
  if (H5Oget_info_by_name3(group, name, &info, H5O_INFO_BASIC, lapl) < 0) return "";
  type = info.type;
  return std::string(reinterpret_cast<const char*>(&info.token), sizeof(info.token));
#else
  H5O_info_t info;
  if (H5Oget_info_by_name2(group, name, &info, H5O_INFO_BASIC, lapl) < 0) return "";
  type = info.type;
  return std::to_string(info.addr);
#endif
}

// "'/data/demo_0'": an object's absolute path, quoted. (Built by appending: GCC 12 warns falsely of overlapping
// copies, -Wrestrict (its bug 105651), for a literal prepended to a temporary string.)
std::string quoted(const char* name) {
  std::string text = "'/";
  text += name;
  text += "'";
  return text;
}

// A soft or external link's value (its target), or "" when it cannot be read.
std::vector<char> link_value(hid_t group, const char* name, std::size_t size, hid_t lapl) {
  std::vector<char> value(size + 1, '\0');
  if (H5Lget_val(group, name, value.data(), value.size(), lapl) < 0) return {};
  return value;
}

// The path a soft link holds.
std::string soft_target(hid_t group, const char* name, std::size_t size, hid_t lapl) {
  const std::vector<char> value = link_value(group, name, size, lapl);
  return value.empty() ? "?" : std::string(value.data());
}

std::string external_target(hid_t group, const char* name, std::size_t size, hid_t lapl) {
  std::vector<char> value = link_value(group, name, size, lapl);
  unsigned flags = 0;
  const char* file = nullptr;
  const char* object = nullptr;
  if (value.empty() || H5Lunpack_elink_val(value.data(), value.size(), &flags, &file, &object) < 0 || !file || !object)
    return "?";
  return std::string(file) + ":" + object;
}

// HDF5's own filters. Any other filter in a dataset's pipeline is code HDF5 would look for in a plugin folder
// (HDF5_PLUGIN_PATH) to read the data: a file from elsewhere would choose a shared object this process loads.
bool built_in_filter(H5Z_filter_t id) {
  return id == H5Z_FILTER_DEFLATE || id == H5Z_FILTER_SHUFFLE || id == H5Z_FILTER_FLETCHER32 || id == H5Z_FILTER_SZIP ||
         id == H5Z_FILTER_NBIT || id == H5Z_FILTER_SCALEOFFSET;
}

// The refusal of the first filter of the dataset's pipeline that is not HDF5's own, or "".
std::string check_filters(hid_t dcpl, const char* name) {
  const int count = H5Pget_nfilters(dcpl);
  if (count < 0) return quoted(name) + ": cannot read the dataset's filter pipeline";
  for (int i = 0; i < count; ++i) {
    unsigned flags = 0;
    std::size_t values = 0;
    char filter_name[128] = {0};
    unsigned config = 0;
    const H5Z_filter_t id = H5Pget_filter2(dcpl, static_cast<unsigned>(i), &flags, &values, nullptr,
                                           sizeof(filter_name), filter_name, &config);
    if (id < 0) return quoted(name) + ": cannot read filter " + std::to_string(i) + " of the dataset's pipeline";
    if (!built_in_filter(id))
      return quoted(name) + " is stored through filter " + std::to_string(id) +
             (filter_name[0] != '\0' ? " ('" + std::string(filter_name) + "')" : std::string()) +
             ", which HDF5 would load from a plugin: this tool reads a file with HDF5's built-in filters only "
             "(deflate, shuffle, fletcher32, szip, nbit, scaleoffset)";
  }
  return "";
}

std::string check_dataset(hid_t group, const char* name) {
  const hid_t dataset = H5Dopen2(group, name, H5P_DEFAULT);
  if (dataset < 0) return quoted(name) + " is a dataset that cannot be opened";
  const hid_t dcpl = H5Dget_create_plist(dataset);
  std::string error;
  if (dcpl < 0) {
    error = quoted(name) + ": cannot read how the dataset is stored";
  } else {
    if (H5Pget_layout(dcpl) == H5D_VIRTUAL) {
      error = quoted(name) + " is a virtual dataset (its data is mapped from other files)" + kWhy;
    } else if (const int count = H5Pget_external_count(dcpl); count != 0) {
      std::string names;
      for (int i = 0; i < count && i < 4; ++i) {
        char file[512] = {0};
        off_t offset = 0;
        hsize_t size = 0;
        if (H5Pget_external(dcpl, static_cast<unsigned>(i), sizeof(file), file, &offset, &size) >= 0)
          names += std::string(names.empty() ? "" : ", ") + "'" + file + "'";
      }
      error = quoted(name) + " keeps its data in external raw files (" + names + ")" + kWhy;
    } else {
      error = check_filters(dcpl, name);
    }
    H5Pclose(dcpl);
  }
  H5Dclose(dataset);
  return error;
}

herr_t visit_link(hid_t group, const char* name, const H5L_info_t* info, void* data) {
  Walk& walk = *static_cast<Walk*>(data);
  const std::string path = quoted(name);
  switch (info->type) {
    case H5L_TYPE_HARD: {
      H5O_type_t type = H5O_TYPE_UNKNOWN;
      const std::string key = object_key(group, name, walk.lapl, type);
      if (key.empty()) {
        walk.error = path + ": cannot read the object's header (damaged file?)";
        return 1;
      }
      if (type == H5O_TYPE_GROUP && !walk.groups.insert(key).second) {
        walk.error = path +
                     " is a group linked twice (a loop of hard links, or an alias); a file of this "
                     "tool reaches each group by one path";
        return 1;
      }
      if (type == H5O_TYPE_DATASET) walk.error = check_dataset(group, name);
      return walk.error.empty() ? 0 : 1;
    }
    case H5L_TYPE_SOFT: {
      const htri_t exists = H5Oexists_by_name(group, name, walk.lapl);
      if (exists <= 0) {
        walk.error = path + " is a soft link to '" + soft_target(group, name, info->u.val_size, walk.lapl) +
                     "' that does not resolve within the file (dangling, a loop of soft links, or through an "
                     "external link)";
        return 1;
      }
      return 0;
    }
    case H5L_TYPE_EXTERNAL:
      walk.error =
          path + " is an external link to '" + external_target(group, name, info->u.val_size, walk.lapl) + "'" + kWhy;
      return 1;
    default:
      walk.error = path + " is a user-defined link (type " + std::to_string(static_cast<int>(info->type)) + ")" + kWhy;
      return 1;
  }
}

}  // namespace

void check_self_contained(hid_t file, const std::string& file_name) {
  Walk walk;
  walk.lapl = H5Pcreate(H5P_LINK_ACCESS);
  if (walk.lapl < 0 || H5Pset_elink_cb(walk.lapl, refuse_external_traversal, nullptr) < 0) {
    if (walk.lapl >= 0) H5Pclose(walk.lapl);
    throw std::runtime_error("HDF5 file '" + file_name + "': cannot set up the check of its links");
  }
  H5O_type_t root_type = H5O_TYPE_UNKNOWN;
  walk.groups.insert(object_key(file, "/", walk.lapl, root_type));
  herr_t status = 0;
  // HDF5 prints its own error stack on failures by default; the refusal below says what is wrong.
  H5E_auto2_t old_func = nullptr;
  void* old_data = nullptr;
  H5Eget_auto2(H5E_DEFAULT, &old_func, &old_data);
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  // H5Lvisit and H5L_info_t name the current API's versions (H5Lvisit2 and H5L_info2_t from HDF5 1.12 on).
  status = H5Lvisit(file, H5_INDEX_NAME, H5_ITER_NATIVE, visit_link, &walk);
  H5Eclear2(H5E_DEFAULT);
  H5Eset_auto2(H5E_DEFAULT, old_func, old_data);
  H5Pclose(walk.lapl);
  if (!walk.error.empty()) throw std::runtime_error("HDF5 file '" + file_name + "': " + walk.error);
  if (status < 0) throw std::runtime_error("HDF5 file '" + file_name + "': cannot walk its links (damaged file?)");
}

}  // namespace maps::io
