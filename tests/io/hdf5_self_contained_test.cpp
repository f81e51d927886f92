#include "io/hdf5_self_contained.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <hdf5.h>

#include <array>
#include <filesystem>
#include <fstream>
#include <functional>
#include <string>

namespace maps::io {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;
namespace fs = std::filesystem;

// Each test builds a small file with HDF5's C API (h5py cannot make a user-defined link; the Python test
// tests/experiments/self_contained_test.py makes the other kinds with h5py and runs every reader on them).
class SelfContained : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("maps_self_contained_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
    H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string path(const std::string& name) const { return (dir_ / name).string(); }

  // A file with /data/x (a 4-element double dataset) and /data/g (an empty group), then `edit` applied.
  std::string make(const std::string& name, const std::function<void(hid_t file)>& edit) {
    const std::string file_name = path(name);
    const hid_t file = H5Fcreate(file_name.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
    EXPECT_GE(file, 0);
    const hid_t data = H5Gcreate2(file, "data", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    write_doubles(data, "x", H5P_DEFAULT);
    H5Gclose(H5Gcreate2(data, "g", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT));
    H5Gclose(data);
    edit(file);
    H5Fclose(file);
    return file_name;
  }

  static void write_doubles(hid_t where, const char* name, hid_t dcpl) {
    const hsize_t dims[1] = {4};
    const hid_t space = H5Screate_simple(1, dims, nullptr);
    const hid_t ds = H5Dcreate2(where, name, H5T_IEEE_F64LE, space, H5P_DEFAULT, dcpl, H5P_DEFAULT);
    ASSERT_GE(ds, 0) << name;
    const std::array<double, 4> values{1, 2, 3, 4};
    ASSERT_GE(H5Dwrite(ds, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, values.data()), 0);
    H5Dclose(ds);
    H5Sclose(space);
  }

  // The error check_self_contained gives for the file, or "" when it accepts it.
  static std::string refusal(const std::string& file_name) {
    const hid_t file = H5Fopen(file_name.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
    EXPECT_GE(file, 0) << file_name;
    std::string error;
    try {
      check_self_contained(file, file_name);
    } catch (const std::runtime_error& e) {
      error = e.what();
    }
    H5Fclose(file);
    return error;
  }

  fs::path dir_;
};

TEST_F(SelfContained, AcceptsAFileOfGroupsDatasetsAttributesAndSoftLinksWithinIt) {
  const std::string file = make("ok.h5", [](hid_t f) {
    ASSERT_GE(H5Lcreate_soft("/data/x", f, "data/alias_of_x", H5P_DEFAULT, H5P_DEFAULT), 0);
    ASSERT_GE(H5Lcreate_soft("/data/g", f, "alias_of_g", H5P_DEFAULT, H5P_DEFAULT), 0);
    // A dataset hard-linked twice is one dataset under two names: nothing outside the file.
    ASSERT_GE(H5Lcreate_hard(f, "/data/x", f, "second_name_of_x", H5P_DEFAULT, H5P_DEFAULT), 0);
    const hid_t space = H5Screate(H5S_SCALAR);
    const hid_t attr = H5Acreate2(f, "count", H5T_STD_I64LE, space, H5P_DEFAULT, H5P_DEFAULT);
    const long long value = 3;
    H5Awrite(attr, H5T_NATIVE_LLONG, &value);
    H5Aclose(attr);
    H5Sclose(space);
  });
  EXPECT_EQ(refusal(file), "");
}

TEST_F(SelfContained, RefusesAnExternalLinkNamingTheFileTheObjectAndTheTarget) {
  const std::string other = make("other.h5", [](hid_t) {});
  const std::string file = make("bad.h5", [&](hid_t f) {
    ASSERT_GE(H5Lcreate_external(other.c_str(), "/data/x", f, "data/stolen", H5P_DEFAULT, H5P_DEFAULT), 0);
  });
  EXPECT_THAT(refusal(file), AllOf(HasSubstr("HDF5 file '" + file + "'"), HasSubstr("'/data/stolen'"),
                                   HasSubstr("external link"), HasSubstr(other + ":/data/x")));
}

TEST_F(SelfContained, RefusesAnExternalLinkToAFileThatDoesNotExist) {
  const std::string file = make("bad.h5", [](hid_t f) {
    ASSERT_GE(H5Lcreate_external("/nowhere/at/all.h5", "/x", f, "dangling", H5P_DEFAULT, H5P_DEFAULT), 0);
  });
  EXPECT_THAT(refusal(file), AllOf(HasSubstr("'/dangling'"), HasSubstr("external link")));
}

TEST_F(SelfContained, RefusesADatasetStoredInExternalRawFiles) {
  const std::string secret = path("secret.bin");
  std::ofstream(secret, std::ios::binary) << std::string(32, 'S');
  const std::string file = make("bad.h5", [&](hid_t f) {
    const hid_t dcpl = H5Pcreate(H5P_DATASET_CREATE);
    ASSERT_GE(H5Pset_external(dcpl, secret.c_str(), 0, 32), 0);
    write_doubles(f, "raw", dcpl);
    H5Pclose(dcpl);
  });
  EXPECT_THAT(refusal(file), AllOf(HasSubstr("'/raw'"), HasSubstr("external raw files"), HasSubstr(secret)));
}

TEST_F(SelfContained, AcceptsHdf5sOwnFiltersAndRefusesAPluginsNamingIt) {
  const std::string ok = make("ok.h5", [](hid_t f) {
    const hsize_t chunk[1] = {2};
    const hid_t dcpl = H5Pcreate(H5P_DATASET_CREATE);
    ASSERT_GE(H5Pset_chunk(dcpl, 1, chunk), 0);
    ASSERT_GE(H5Pset_shuffle(dcpl), 0);
    ASSERT_GE(H5Pset_deflate(dcpl, 4), 0);
    ASSERT_GE(H5Pset_fletcher32(dcpl), 0);
    write_doubles(f, "compressed", dcpl);
    H5Pclose(dcpl);
  });
  EXPECT_EQ(refusal(ok), "");
  // 32001 is Blosc's registered id: a plugin, not part of HDF5. Optional, so that the file can be written here
  // without it (the chunks record it as skipped); the pipeline still names it, and a reader with the plugin would
  // load it.
  const std::string bad = make("bad.h5", [](hid_t f) {
    const hsize_t chunk[1] = {2};
    const hid_t dcpl = H5Pcreate(H5P_DATASET_CREATE);
    ASSERT_GE(H5Pset_chunk(dcpl, 1, chunk), 0);
    ASSERT_GE(H5Pset_deflate(dcpl, 4), 0);
    ASSERT_GE(H5Pset_filter(dcpl, 32001, H5Z_FLAG_OPTIONAL, 0, nullptr), 0);
    write_doubles(f, "blosc", dcpl);
    H5Pclose(dcpl);
  });
  EXPECT_THAT(refusal(bad), AllOf(HasSubstr("HDF5 file '" + bad + "'"), HasSubstr("'/blosc'"),
                                  HasSubstr("filter 32001"), HasSubstr("load from a plugin")));
}

TEST_F(SelfContained, RefusesAVirtualDataset) {
  const std::string other = make("other.h5", [](hid_t) {});
  const std::string file = make("bad.h5", [&](hid_t f) {
    const hsize_t dims[1] = {4};
    const hid_t space = H5Screate_simple(1, dims, nullptr);
    const hid_t dcpl = H5Pcreate(H5P_DATASET_CREATE);
    ASSERT_GE(H5Pset_virtual(dcpl, space, other.c_str(), "/data/x", space), 0);
    const hid_t ds = H5Dcreate2(f, "data/virtual", H5T_IEEE_F64LE, space, H5P_DEFAULT, dcpl, H5P_DEFAULT);
    ASSERT_GE(ds, 0);
    H5Dclose(ds);
    H5Pclose(dcpl);
    H5Sclose(space);
  });
  EXPECT_THAT(refusal(file), AllOf(HasSubstr("'/data/virtual'"), HasSubstr("virtual dataset")));
}

// A traversal that never resolves: the check must refuse the link by its type without traversing it.
hid_t never_traverse(const char*, hid_t, const void*, size_t, hid_t, hid_t) { return -1; }

TEST_F(SelfContained, RefusesAUserDefinedLink) {
  constexpr auto kType = static_cast<H5L_type_t>(65);
  const H5L_class_t ud_class{H5L_LINK_CLASS_T_VERS, kType,   "maps test link", nullptr, nullptr, nullptr,
                             never_traverse,        nullptr, nullptr};
  ASSERT_GE(H5Lregister(&ud_class), 0);
  const std::string file = make("bad.h5", [&](hid_t f) {
    const char payload[] = "/etc/passwd";
    ASSERT_GE(H5Lcreate_ud(f, "data/custom", kType, payload, sizeof payload, H5P_DEFAULT, H5P_DEFAULT), 0);
  });
  H5Lunregister(kType);
  EXPECT_THAT(refusal(file), AllOf(HasSubstr("'/data/custom'"), HasSubstr("user-defined link (type 65)")));
}

TEST_F(SelfContained, RefusesADanglingSoftLink) {
  const std::string file = make("bad.h5", [](hid_t f) {
    ASSERT_GE(H5Lcreate_soft("/data/nothing_here", f, "data/y", H5P_DEFAULT, H5P_DEFAULT), 0);
  });
  EXPECT_THAT(refusal(file), AllOf(HasSubstr("'/data/y'"), HasSubstr("soft link to '/data/nothing_here'"),
                                   HasSubstr("does not resolve")));
}

TEST_F(SelfContained, RefusesALoopOfSoftLinks) {
  const std::string file = make("bad.h5", [](hid_t f) {
    ASSERT_GE(H5Lcreate_soft("/b", f, "a", H5P_DEFAULT, H5P_DEFAULT), 0);
    ASSERT_GE(H5Lcreate_soft("/a", f, "b", H5P_DEFAULT, H5P_DEFAULT), 0);
  });
  EXPECT_THAT(refusal(file), AllOf(HasSubstr("soft link to '/"), HasSubstr("does not resolve")));
}

TEST_F(SelfContained, RefusesASoftLinkThatLeavesTheFileThroughAnExternalLink) {
  const std::string other = make("other.h5", [](hid_t) {});
  const std::string file = make("bad.h5", [&](hid_t f) {
    // "a" sorts before "z": the soft link is met first, and must not be followed out of the file.
    ASSERT_GE(H5Lcreate_soft("/z/data/x", f, "a", H5P_DEFAULT, H5P_DEFAULT), 0);
    ASSERT_GE(H5Lcreate_external(other.c_str(), "/", f, "z", H5P_DEFAULT, H5P_DEFAULT), 0);
  });
  EXPECT_THAT(refusal(file), AllOf(HasSubstr("'/a'"), HasSubstr("does not resolve")));
}

TEST_F(SelfContained, RefusesAHardLinkLoopOfGroups) {
  const std::string file = make("bad.h5", [](hid_t f) {
    ASSERT_GE(H5Lcreate_hard(f, "/data", f, "data/g/back_up", H5P_DEFAULT, H5P_DEFAULT), 0);
  });
  EXPECT_THAT(refusal(file), AllOf(HasSubstr("group linked twice"), HasSubstr("'/data")));
}

TEST_F(SelfContained, RefusesAHardLinkToTheRootGroup) {
  const std::string file = make("bad.h5", [](hid_t f) {
    ASSERT_GE(H5Lcreate_hard(f, "/", f, "data/g/root_again", H5P_DEFAULT, H5P_DEFAULT), 0);
  });
  EXPECT_THAT(refusal(file), AllOf(HasSubstr("'/data/g/root_again'"), HasSubstr("group linked twice")));
}

}  // namespace
}  // namespace maps::io
