#include "envs/demo_file.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <hdf5.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <random>
#include <set>
#include <stdexcept>
#include <string>
#include <tuple>
#include <vector>

#include "envs/demo_file/hdf5_reader.h"
#include "tests/common/temp_folder.h"

namespace maps::envs {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

class DemoFileTest : public TempFolderTest {
 protected:
  DemoFileTest() : TempFolderTest("maps_envs_demo_file_") {}
  std::vector<std::string> listing() const {
    std::vector<std::string> names;
    for (const auto& entry : fs::directory_iterator(dir_)) names.push_back(entry.path().filename().string());
    return names;
  }
};

Demonstration make_demo(int steps, int obs_dim, int act_dim, const std::string& task, std::int64_t task_index,
                        std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal;
  Demonstration d;
  d.task = task;
  d.task_index = task_index;
  d.seed = seed;
  d.obs.resize(steps, obs_dim);
  d.actions.resize(steps, act_dim);
  d.rewards.resize(steps);
  for (int t = 0; t < steps; ++t) {
    for (int j = 0; j < obs_dim; ++j) d.obs(t, j) = normal(rng) * 1e3;
    for (int j = 0; j < act_dim; ++j) d.actions(t, j) = normal(rng);
    d.rewards(t) = normal(rng);
  }
  d.obs(0, 0) = 0.1;                                                  // not exactly representable
  d.obs(0, obs_dim - 1) = std::numeric_limits<double>::denorm_min();  // bits survive
  d.dones.assign(static_cast<std::size_t>(steps), 0);
  d.dones.back() = 1;
  d.episode_return = d.rewards.sum();
  d.success = seed % 2 == 0;
  d.final_obs = Eigen::VectorXd::Constant(obs_dim, 0.25 * static_cast<double>(seed));
  d.end = seed % 2 == 0 ? EpisodeEnd::kTerminated : EpisodeEnd::kTruncated;
  return d;
}

// 5 demos over 2 tasks, obs 4-d, actions 3-d, lengths 6..10.
DemoFile make_file(int n_demos = 5) {
  DemoFile f;
  f.task_set = "gravity";
  f.task_names = {"gravity/0.5", "gravity/1.5"};
  f.env_version = "HalfCheetah maps-1 / MuJoCo 2.2.2";
  f.creation_command = "maps collect --set gravity --demos 35 --out \"demos file.h5\"";
  f.extra_json = R"({"discarded": 2, "actions": "mean", "note": "ünïcode"})";
  for (int i = 0; i < n_demos; ++i)
    f.demos.push_back(make_demo(6 + i, 4, 3, f.task_names[static_cast<std::size_t>(i % 2)], i % 2, 1000 + i));
  std::tie(f.train, f.valid) = split_train_valid(n_demos, 0.7, 3);
  return f;
}

// The message of the exception `fn` throws ("" and a test failure if it throws none).
template <typename Exception = std::exception>
std::string error_of(const std::function<void()>& fn) {
  try {
    fn();
  } catch (const Exception& e) {
    return e.what();
  }
  ADD_FAILURE() << "no exception thrown";
  return "";
}

// ----- raw HDF5 editing, to damage a valid file -----

void edit(const std::string& file, const std::function<void(hid_t)>& fn) {
  const hid_t f = H5Fopen(file.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
  ASSERT_GE(f, 0);
  fn(f);
  ASSERT_GE(H5Fclose(f), 0);
}

void replace_dataset(hid_t f, const std::string& name, const std::vector<hsize_t>& dims, const double* data) {
  ASSERT_GE(H5Ldelete(f, name.c_str(), H5P_DEFAULT), 0);
  const hid_t space = H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr);
  const hid_t ds = H5Dcreate2(f, name.c_str(), H5T_IEEE_F64LE, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  ASSERT_GE(ds, 0);
  ASSERT_GE(H5Dwrite(ds, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, data), 0);
  H5Dclose(ds);
  H5Sclose(space);
}

void replace_mask(hid_t f, const std::string& name, const std::vector<std::string>& values) {
  ASSERT_GE(H5Ldelete(f, name.c_str(), H5P_DEFAULT), 0);
  const hid_t type = H5Tcopy(H5T_C_S1);
  H5Tset_size(type, H5T_VARIABLE);  // variable-length this time: the reader takes both kinds
  const hsize_t n = values.size();
  const hid_t space = H5Screate_simple(1, &n, nullptr);
  const hid_t ds = H5Dcreate2(f, name.c_str(), type, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  ASSERT_GE(ds, 0);
  std::vector<const char*> pointers;
  for (const auto& v : values) pointers.push_back(v.c_str());
  ASSERT_GE(H5Dwrite(ds, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, pointers.data()), 0);
  H5Dclose(ds);
  H5Sclose(space);
  H5Tclose(type);
}

void set_int64_attr(hid_t f, const char* object, const char* name, std::int64_t value) {
  if (H5Aexists_by_name(f, object, name, H5P_DEFAULT) > 0) {
    ASSERT_GE(H5Adelete_by_name(f, object, name, H5P_DEFAULT), 0);
  }
  const hid_t space = H5Screate(H5S_SCALAR);
  const hid_t attr = H5Acreate_by_name(f, object, name, H5T_STD_I64LE, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  ASSERT_GE(attr, 0);
  ASSERT_GE(H5Awrite(attr, H5T_NATIVE_INT64, &value), 0);
  H5Aclose(attr);
  H5Sclose(space);
}

void set_string_attr(hid_t f, const char* object, const char* name, const std::string& value) {
  if (H5Aexists_by_name(f, object, name, H5P_DEFAULT) > 0) {
    ASSERT_GE(H5Adelete_by_name(f, object, name, H5P_DEFAULT), 0);
  }
  const hid_t type = H5Tcopy(H5T_C_S1);
  H5Tset_size(type, value.size() + 1);
  const hid_t space = H5Screate(H5S_SCALAR);
  const hid_t attr = H5Acreate_by_name(f, object, name, type, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  ASSERT_GE(attr, 0);
  ASSERT_GE(H5Awrite(attr, type, value.c_str()), 0);
  H5Aclose(attr);
  H5Sclose(space);
  H5Tclose(type);
}

// Rewrites a format 2 file as format 1 had it: obs a dataset, no next_obs, env_args or episode_end.
void downgrade_to_format_1(hid_t f, int n_demos) {
  for (int i = 0; i < n_demos; ++i) {
    const std::string demo = "data/" + demo_name(i);
    ASSERT_GE(H5Lmove(f, (demo + "/obs/flat").c_str(), f, (demo + "/obs_v1").c_str(), H5P_DEFAULT, H5P_DEFAULT), 0);
    ASSERT_GE(H5Ldelete(f, (demo + "/obs").c_str(), H5P_DEFAULT), 0);
    ASSERT_GE(H5Lmove(f, (demo + "/obs_v1").c_str(), f, (demo + "/obs").c_str(), H5P_DEFAULT, H5P_DEFAULT), 0);
    ASSERT_GE(H5Ldelete(f, (demo + "/next_obs").c_str(), H5P_DEFAULT), 0);
    ASSERT_GE(H5Adelete_by_name(f, demo.c_str(), "episode_end", H5P_DEFAULT), 0);
  }
  ASSERT_GE(H5Adelete_by_name(f, "data", "env_args", H5P_DEFAULT), 0);
  set_int64_attr(f, "data", "format_version", 1);
}

// ----- round trip and layout -----

TEST_F(DemoFileTest, RoundTripIsExact) {
  const DemoFile in = make_file();
  write_demo_file(path("demos.h5"), in);
  const DemoFile out = read_demo_file(path("demos.h5"));
  EXPECT_EQ(out.task_set, in.task_set);
  EXPECT_EQ(out.task_names, in.task_names);
  EXPECT_EQ(out.env_version, in.env_version);
  EXPECT_EQ(out.creation_command, in.creation_command);
  EXPECT_EQ(out.extra_json, in.extra_json);
  EXPECT_EQ(out.train, in.train);
  EXPECT_EQ(out.valid, in.valid);
  ASSERT_EQ(out.demos.size(), in.demos.size());
  for (std::size_t i = 0; i < in.demos.size(); ++i) {
    const Demonstration &a = in.demos[i], &b = out.demos[i];
    SCOPED_TRACE("demo " + std::to_string(i));
    EXPECT_EQ(b.task, a.task);
    EXPECT_EQ(b.task_index, a.task_index);
    EXPECT_EQ(b.seed, a.seed);
    ASSERT_EQ(b.obs.rows(), a.obs.rows());
    ASSERT_EQ(b.obs.cols(), a.obs.cols());
    EXPECT_TRUE(b.obs == a.obs);
    ASSERT_EQ(b.actions.rows(), a.actions.rows());
    ASSERT_EQ(b.actions.cols(), a.actions.cols());
    EXPECT_TRUE(b.actions == a.actions);
    ASSERT_EQ(b.rewards.size(), a.rewards.size());
    EXPECT_TRUE(b.rewards == a.rewards);
    EXPECT_EQ(b.dones, a.dones);
    EXPECT_EQ(b.episode_return, a.episode_return);
    EXPECT_EQ(b.success, a.success);
    EXPECT_TRUE(b.final_obs == a.final_obs);
    EXPECT_EQ(b.end, a.end);
  }
  EXPECT_EQ(out.total_samples(), in.total_samples());
  EXPECT_EQ(out.format_version, 2);
}

TEST_F(DemoFileTest, LargeSeedAndEmptyMetadataRoundTrip) {
  DemoFile in = make_file(2);
  in.demos[1].seed = std::numeric_limits<std::uint64_t>::max();
  in.task_set.clear();
  in.env_version.clear();
  in.creation_command.clear();
  in.valid.clear();  // an empty mask is allowed
  in.train = {0, 1};
  write_demo_file(path("demos.h5"), in);
  const DemoFile out = read_demo_file(path("demos.h5"));
  EXPECT_EQ(out.demos[1].seed, std::numeric_limits<std::uint64_t>::max());
  EXPECT_EQ(out.task_set, "");
  EXPECT_EQ(out.train, (std::vector<int>{0, 1}));
  EXPECT_TRUE(out.valid.empty());
}

// The reader turns libhdf5's plugin loading off while it reads (a file from elsewhere must not choose code to load)
// and gives the host back the state it had: the Python module's host may read its own files with plugins.
TEST_F(DemoFileTest, PluginLoadingIsRestoredAfterAReadAndARefusal) {
  unsigned before = 0;
  ASSERT_GE(H5PLget_loading_state(&before), 0);
  ASSERT_GE(H5PLset_loading_state(H5PL_FILTER_PLUGIN), 0);  // not the default (all), so a reset would show
  write_demo_file(path("demos.h5"), make_file());
  read_demo_file(path("demos.h5"));
  unsigned after = 0;
  ASSERT_GE(H5PLget_loading_state(&after), 0);
  EXPECT_EQ(after, static_cast<unsigned>(H5PL_FILTER_PLUGIN));
  std::ofstream(path("not.h5")) << "not HDF5";
  EXPECT_THAT(error_of([&] { read_demo_file(path("not.h5")); }), HasSubstr("not an HDF5 file"));
  ASSERT_GE(H5PLget_loading_state(&after), 0);
  EXPECT_EQ(after, static_cast<unsigned>(H5PL_FILTER_PLUGIN));
  H5PLset_loading_state(before);
}

// While a reader lives libhdf5 loads no plugin, whatever the state before (the security claim; the test above checks
// the state is given back).
TEST_F(DemoFileTest, NoPluginIsLoadedWhileAReaderLives) {
  unsigned before = 0, state = 99;
  ASSERT_GE(H5PLget_loading_state(&before), 0);
  ASSERT_GE(H5PLset_loading_state(H5PL_ALL_PLUGIN), 0);
  {
    const demo_file_detail::Hdf5Reader reader(path("any.h5"));
    ASSERT_GE(H5PLget_loading_state(&state), 0);
    EXPECT_EQ(state, 0u);
  }
  ASSERT_GE(H5PLget_loading_state(&state), 0);
  EXPECT_EQ(state, static_cast<unsigned>(H5PL_ALL_PLUGIN));
  H5PLset_loading_state(before);
}

// The layout h5py/robomimic users rely on, checked with the plain HDF5 API.
TEST_F(DemoFileTest, LayoutIsRobomimicStyle) {
  const DemoFile in = make_file();
  write_demo_file(path("demos.h5"), in);
  const hid_t f = H5Fopen(path("demos.h5").c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  ASSERT_GE(f, 0);
  for (const char* attr : {"task_set", "task_names", "env_version", "creation_command", "extra_json", "total",
                           "num_demos", "format_version", "env_args"})
    EXPECT_GT(H5Aexists_by_name(f, "data", attr, H5P_DEFAULT), 0) << attr;
  for (const char* attr : {"task", "task_index", "num_samples", "return", "success", "seed", "episode_end"})
    EXPECT_GT(H5Aexists_by_name(f, "data/demo_2", attr, H5P_DEFAULT), 0) << attr;

  // next_obs/flat is obs/flat one row on, then the final observation.
  std::vector<double> next(32);
  const hid_t next_ds = H5Dopen2(f, "data/demo_2/next_obs/flat", H5P_DEFAULT);
  ASSERT_GE(next_ds, 0);
  H5Dread(next_ds, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, next.data());
  H5Dclose(next_ds);
  EXPECT_EQ(next[0 * 4 + 2], in.demos[2].obs(1, 2));
  EXPECT_EQ(next[7 * 4 + 3], in.demos[2].final_obs(3));

  // data/demo_2/obs/flat is float64 [T, obs_dim], row-major: element (t, j) at t * obs_dim + j.
  const hid_t ds = H5Dopen2(f, "data/demo_2/obs/flat", H5P_DEFAULT);
  ASSERT_GE(ds, 0);
  const hid_t space = H5Dget_space(ds);
  hsize_t dims[2] = {0, 0};
  ASSERT_EQ(H5Sget_simple_extent_ndims(space), 2);
  H5Sget_simple_extent_dims(space, dims, nullptr);
  EXPECT_EQ(dims[0], 8u);
  EXPECT_EQ(dims[1], 4u);
  const hid_t type = H5Dget_type(ds);
  EXPECT_EQ(H5Tget_class(type), H5T_FLOAT);
  EXPECT_EQ(H5Tget_size(type), 8u);
  std::vector<double> flat(32);
  H5Dread(ds, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, flat.data());
  EXPECT_EQ(flat[1 * 4 + 2], in.demos[2].obs(1, 2));
  H5Tclose(type);
  H5Sclose(space);
  H5Dclose(ds);

  // mask/train: fixed-length strings naming demos.
  const hid_t mask = H5Dopen2(f, "mask/train", H5P_DEFAULT);
  ASSERT_GE(mask, 0);
  const hid_t mtype = H5Dget_type(mask);
  EXPECT_EQ(H5Tget_class(mtype), H5T_STRING);
  EXPECT_EQ(H5Tis_variable_str(mtype), 0);
  const std::size_t width = H5Tget_size(mtype);
  std::string buffer(in.train.size() * width, '\0');
  H5Dread(mask, mtype, H5S_ALL, H5S_ALL, H5P_DEFAULT, buffer.data());
  EXPECT_EQ(std::string(buffer.substr(0, width).c_str()), demo_name(in.train[0]));
  H5Tclose(mtype);
  H5Dclose(mask);
  H5Fclose(f);
}

// ----- format versions -----

TEST_F(DemoFileTest, FormatOneFilesStillReadButCannotBeWrittenAsFormatTwo) {
  const DemoFile in = make_file();
  write_demo_file(path("demos.h5"), in);
  edit(path("demos.h5"), [&](hid_t f) { downgrade_to_format_1(f, 5); });
  const DemoFile old = read_demo_file(path("demos.h5"));
  EXPECT_EQ(old.format_version, 1);
  ASSERT_EQ(old.demos.size(), in.demos.size());
  for (std::size_t i = 0; i < in.demos.size(); ++i) {
    EXPECT_TRUE(old.demos[i].obs == in.demos[i].obs);
    EXPECT_TRUE(old.demos[i].actions == in.demos[i].actions);
    EXPECT_EQ(old.demos[i].final_obs.size(), 0);
    EXPECT_EQ(old.demos[i].end, EpisodeEnd::kUnknown);
  }
  const std::string error = error_of([&] { write_demo_file(path("again.h5"), old); });
  EXPECT_THAT(error, HasSubstr("data/demo_0 has no final observation"));
  EXPECT_THAT(error, HasSubstr("format 1"));
  EXPECT_THAT(error, HasSubstr("with `" + in.creation_command + "`"));
  EXPECT_FALSE(fs::exists(path("again.h5")));
}

TEST_F(DemoFileTest, AFormatVersionThisReaderDoesNotKnowIsNamed) {
  for (const std::int64_t version : {std::int64_t{0}, std::int64_t{3}}) {
    write_demo_file(path("demos.h5"), make_file());
    edit(path("demos.h5"), [&](hid_t f) { set_int64_attr(f, "data", "format_version", version); });
    EXPECT_THAT(error_of([&] { read_demo_file(path("demos.h5")); }),
                HasSubstr("unsupported format_version " + std::to_string(version) + " (this reader knows 1 to 2)"));
  }
}

TEST_F(DemoFileTest, NextObsThatIsNotObsOneStepOnIsNamed) {
  const DemoFile in = make_file();
  write_demo_file(path("demos.h5"), in);
  // demo_1 has 7 steps: next_obs row 2 should be obs row 3.
  std::vector<double> next(7 * 4);
  for (int t = 0; t < 7; ++t)
    for (int j = 0; j < 4; ++j) next[static_cast<std::size_t>(t * 4 + j)] = t + 1 < 7 ? in.demos[1].obs(t + 1, j) : 0.0;
  next[2 * 4 + 1] += 1e-9;
  edit(path("demos.h5"), [&](hid_t f) { replace_dataset(f, "data/demo_1/next_obs/flat", {7, 4}, next.data()); });
  EXPECT_THAT(error_of([&] { read_demo_file(path("demos.h5")); }),
              HasSubstr("data/demo_1/next_obs/flat: row 2 differs from data/demo_1/obs/flat row 3"));

  write_demo_file(path("demos.h5"), in);
  edit(path("demos.h5"), [&](hid_t f) { replace_dataset(f, "data/demo_1/next_obs/flat", {6, 4}, next.data()); });
  EXPECT_THAT(error_of([&] { read_demo_file(path("demos.h5")); }),
              HasSubstr("data/demo_1/next_obs/flat: has shape [6, 4] but data/demo_1/obs/flat has [7, 4]"));

  write_demo_file(path("demos.h5"), in);
  edit(path("demos.h5"), [](hid_t f) { ASSERT_GE(H5Ldelete(f, "data/demo_4/next_obs", H5P_DEFAULT), 0); });
  EXPECT_THAT(error_of([&] { read_demo_file(path("demos.h5")); }), HasSubstr("data/demo_4/next_obs: missing group"));
}

TEST_F(DemoFileTest, AnEpisodeEndOtherThanTerminatedOrTruncatedIsNamed) {
  write_demo_file(path("demos.h5"), make_file());
  edit(path("demos.h5"), [](hid_t f) { set_string_attr(f, "data/demo_2", "episode_end", "crashed"); });
  EXPECT_THAT(error_of([&] { read_demo_file(path("demos.h5")); }),
              HasSubstr("data/demo_2: attribute episode_end should be 'terminated' or 'truncated', got 'crashed'"));
}

TEST_F(DemoFileTest, EnvArgsThatAreNotJsonAreNamed) {
  write_demo_file(path("demos.h5"), make_file());
  edit(path("demos.h5"), [](hid_t f) { set_string_attr(f, "data", "env_args", "{not json"); });
  EXPECT_THAT(error_of([&] { read_demo_file(path("demos.h5")); }), HasSubstr("data: attribute env_args is not JSON"));
}

// ----- split -----

TEST(SplitTrainValid, EveryDemoInExactlyOneSetDeterministically) {
  for (int n : {2, 3, 5, 10, 35, 100}) {
    SCOPED_TRACE("n = " + std::to_string(n));
    const auto [train, valid] = split_train_valid(n, 0.7, 42);
    EXPECT_GE(train.size(), 1u);
    EXPECT_GE(valid.size(), 1u);
    std::vector<int> all(train);
    all.insert(all.end(), valid.begin(), valid.end());
    std::sort(all.begin(), all.end());
    std::vector<int> expected(static_cast<std::size_t>(n));
    for (int i = 0; i < n; ++i) expected[static_cast<std::size_t>(i)] = i;
    EXPECT_EQ(all, expected);
    EXPECT_TRUE(std::is_sorted(train.begin(), train.end()));
    EXPECT_TRUE(std::is_sorted(valid.begin(), valid.end()));
    const auto again = split_train_valid(n, 0.7, 42);
    EXPECT_EQ(again.first, train);
    EXPECT_EQ(again.second, valid);
  }
  // floor(0.3 * n) valid, as robomimic: 35 -> 25 / 10, 10 -> 7 / 3, 2 -> 1 / 1.
  EXPECT_EQ(split_train_valid(35, 0.7, 1).second.size(), 10u);
  EXPECT_EQ(split_train_valid(10, 0.7, 1).second.size(), 3u);
  EXPECT_EQ(split_train_valid(2, 0.9, 1).second.size(), 1u);
  EXPECT_EQ(split_train_valid(2, 0.1, 1).first.size(), 1u);
  EXPECT_EQ(split_train_valid(1, 0.7, 1).first, std::vector<int>{0});
  EXPECT_TRUE(split_train_valid(1, 0.7, 1).second.empty());
  EXPECT_TRUE(split_train_valid(0, 0.7, 1).first.empty());
  // Different seeds give different splits (fixed expectation for these two seeds).
  EXPECT_NE(split_train_valid(35, 0.7, 1).second, split_train_valid(35, 0.7, 2).second);
  EXPECT_THROW(split_train_valid(10, 1.0, 1), std::invalid_argument);
  EXPECT_THROW(split_train_valid(10, 0.0, 1), std::invalid_argument);
  EXPECT_THROW(split_train_valid(-1, 0.7, 1), std::invalid_argument);
}

// ----- damaged files -----

TEST_F(DemoFileTest, MissingFileIsNamed) {
  const std::string msg = error_of([&] { read_demo_file(path("absent.h5")); });
  EXPECT_THAT(msg, HasSubstr(path("absent.h5")));
  EXPECT_THAT(msg, HasSubstr("no such file"));
}

TEST_F(DemoFileTest, NotAnHdf5FileIsRefused) {
  std::mt19937 rng(7);
  std::ofstream out(path("random.h5"), std::ios::binary);
  for (int i = 0; i < 4096; ++i) out.put(static_cast<char>(rng() & 0xff));
  out.close();
  const std::string msg = error_of([&] { read_demo_file(path("random.h5")); });
  EXPECT_THAT(msg, HasSubstr(path("random.h5")));
  EXPECT_THAT(msg, HasSubstr("not an HDF5 file"));
}

TEST_F(DemoFileTest, TruncatedFileIsRefused) {
  write_demo_file(path("demos.h5"), make_file());
  fs::resize_file(path("demos.h5"), fs::file_size(path("demos.h5")) / 2);
  const std::string msg = error_of([&] { read_demo_file(path("demos.h5")); });
  EXPECT_THAT(msg, HasSubstr(path("demos.h5")));
  EXPECT_THAT(msg, HasSubstr("truncated"));
}

TEST_F(DemoFileTest, MissingDatasetIsNamed) {
  write_demo_file(path("demos.h5"), make_file());
  edit(path("demos.h5"), [](hid_t f) { ASSERT_GE(H5Ldelete(f, "data/demo_1/actions", H5P_DEFAULT), 0); });
  const std::string msg = error_of([&] { read_demo_file(path("demos.h5")); });
  EXPECT_THAT(msg, HasSubstr(path("demos.h5")));
  EXPECT_THAT(msg, HasSubstr("data/demo_1/actions: missing dataset"));
}

TEST_F(DemoFileTest, MissingGroupsAreNamed) {
  write_demo_file(path("demos.h5"), make_file());
  edit(path("demos.h5"), [](hid_t f) { ASSERT_GE(H5Ldelete(f, "data/demo_4", H5P_DEFAULT), 0); });
  EXPECT_THAT(error_of([&] { read_demo_file(path("demos.h5")); }), HasSubstr("data/demo_4: missing group"));

  write_demo_file(path("demos.h5"), make_file());
  edit(path("demos.h5"), [](hid_t f) { ASSERT_GE(H5Ldelete(f, "mask", H5P_DEFAULT), 0); });
  EXPECT_THAT(error_of([&] { read_demo_file(path("demos.h5")); }), HasSubstr("mask: missing group"));

  write_demo_file(path("demos.h5"), make_file());
  edit(path("demos.h5"), [](hid_t f) { ASSERT_GE(H5Ldelete(f, "mask/valid", H5P_DEFAULT), 0); });
  EXPECT_THAT(error_of([&] { read_demo_file(path("demos.h5")); }), HasSubstr("mask/valid: missing dataset"));
}

TEST_F(DemoFileTest, MissingAttributeIsNamed) {
  write_demo_file(path("demos.h5"), make_file());
  edit(path("demos.h5"), [](hid_t f) { ASSERT_GE(H5Adelete_by_name(f, "data/demo_3", "task", H5P_DEFAULT), 0); });
  EXPECT_THAT(error_of([&] { read_demo_file(path("demos.h5")); }), HasSubstr("data/demo_3: missing attribute 'task'"));

  write_demo_file(path("demos.h5"), make_file());
  edit(path("demos.h5"), [](hid_t f) { ASSERT_GE(H5Adelete_by_name(f, "data", "task_names", H5P_DEFAULT), 0); });
  EXPECT_THAT(error_of([&] { read_demo_file(path("demos.h5")); }), HasSubstr("data: missing attribute 'task_names'"));
}

// Found by fuzz/fuzz_demo_file.cpp: num_demos = 2^31 - 1 made the reader name two billion demos before noticing
// they are not there (a hang of minutes and gigabytes).
TEST_F(DemoFileTest, ANumDemosOtherThanTheMembersIsRefusedAtOnce) {
  for (const std::int64_t claimed : {std::int64_t{2147483647}, std::int64_t{6}, std::int64_t{4}, std::int64_t{0}}) {
    write_demo_file(path("demos.h5"), make_file());
    edit(path("demos.h5"), [&](hid_t f) {
      ASSERT_GE(H5Adelete_by_name(f, "data", "num_demos", H5P_DEFAULT), 0);
      const hid_t space = H5Screate(H5S_SCALAR);
      const hid_t attr =
          H5Acreate_by_name(f, "data", "num_demos", H5T_STD_I64LE, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
      ASSERT_GE(attr, 0);
      ASSERT_GE(H5Awrite(attr, H5T_NATIVE_INT64, &claimed), 0);
      H5Aclose(attr);
      H5Sclose(space);
    });
    const std::string error = error_of([&] { read_demo_file(path("demos.h5")); });
    if (claimed > 5)
      EXPECT_THAT(error, HasSubstr("data/demo_5: missing group (attribute num_demos is " + std::to_string(claimed) +
                                   ", data holds 5 members)"));
    else
      EXPECT_THAT(error, HasSubstr("data/demo_" + std::to_string(claimed) + ": unexpected member"));
  }
}

TEST_F(DemoFileTest, WrongShapeNamesTheDemo) {
  write_demo_file(path("demos.h5"), make_file());
  // demo_1 has 7 steps; give it 6 rows of actions.
  const std::vector<double> actions(6 * 3, 0.5);
  edit(path("demos.h5"), [&](hid_t f) { replace_dataset(f, "data/demo_1/actions", {6, 3}, actions.data()); });
  const std::string msg = error_of([&] { read_demo_file(path("demos.h5")); });
  EXPECT_THAT(msg, HasSubstr("data/demo_1/actions: has 6 rows"));
  EXPECT_THAT(msg, HasSubstr("data/demo_1/obs/flat has 7"));
}

TEST_F(DemoFileTest, WrongRankIsNamed) {
  write_demo_file(path("demos.h5"), make_file());
  const std::vector<double> rewards(7 * 2, 0.5);
  edit(path("demos.h5"), [&](hid_t f) { replace_dataset(f, "data/demo_1/rewards", {7, 2}, rewards.data()); });
  EXPECT_THAT(error_of([&] { read_demo_file(path("demos.h5")); }),
              HasSubstr("data/demo_1/rewards: expected a 1-d dataset, found rank 2"));
}

TEST_F(DemoFileTest, ObservationWidthDifferingAcrossDemosIsNamed) {
  write_demo_file(path("demos.h5"), make_file());
  const std::vector<double> obs(8 * 5, 0.5);  // demo_2 has 8 steps; 5 columns instead of 4
  edit(path("demos.h5"), [&](hid_t f) { replace_dataset(f, "data/demo_2/obs/flat", {8, 5}, obs.data()); });
  const std::string msg = error_of([&] { read_demo_file(path("demos.h5")); });
  EXPECT_THAT(msg, HasSubstr("data/demo_2/obs/flat: has 5 columns but data/demo_0's has 4"));
}

TEST_F(DemoFileTest, MaskNamingAMissingDemoIsNamed) {
  write_demo_file(path("demos.h5"), make_file());
  edit(path("demos.h5"), [](hid_t f) { replace_mask(f, "mask/train", {"demo_0", "demo_9"}); });
  const std::string msg = error_of([&] { read_demo_file(path("demos.h5")); });
  EXPECT_THAT(msg, HasSubstr("mask/train: names 'demo_9', which is not a demo in data"));
}

TEST_F(DemoFileTest, VariableLengthMasksAreRead) {
  const DemoFile in = make_file();
  write_demo_file(path("demos.h5"), in);
  std::vector<std::string> names;
  for (int i : in.valid) names.push_back(demo_name(i));
  edit(path("demos.h5"), [&](hid_t f) { replace_mask(f, "mask/valid", names); });
  EXPECT_EQ(read_demo_file(path("demos.h5")).valid, in.valid);
}

TEST_F(DemoFileTest, NaNInTheFileIsNamed) {
  const DemoFile in = make_file();
  write_demo_file(path("demos.h5"), in);
  Eigen::VectorXd rewards = in.demos[3].rewards;  // 9 steps
  rewards(4) = std::numeric_limits<double>::quiet_NaN();
  edit(path("demos.h5"), [&](hid_t f) { replace_dataset(f, "data/demo_3/rewards", {9}, rewards.data()); });
  EXPECT_THAT(error_of([&] { read_demo_file(path("demos.h5")); }), HasSubstr("data/demo_3/rewards: NaN at step 4"));
}

// ----- invalid input to the writer -----

TEST_F(DemoFileTest, InvalidInputIsRefusedAndNothingIsWritten) {
  {
    DemoFile f = make_file();
    f.demos[2].actions.conservativeResize(f.demos[2].actions.rows() - 1, Eigen::NoChange);
    EXPECT_THAT(error_of<std::invalid_argument>([&] { write_demo_file(path("demos.h5"), f); }),
                HasSubstr("data/demo_2: actions has 7 rows but obs has 8"));
  }
  {
    DemoFile f = make_file();
    f.demos[1].obs(2, 3) = std::numeric_limits<double>::quiet_NaN();
    EXPECT_THAT(error_of<std::invalid_argument>([&] { write_demo_file(path("demos.h5"), f); }),
                HasSubstr("data/demo_1/obs: NaN at row 2, column 3"));
  }
  {
    DemoFile f = make_file();
    f.demos[4].obs.conservativeResize(Eigen::NoChange, 5);
    f.demos[4].obs.col(4).setZero();
    EXPECT_THAT(error_of<std::invalid_argument>([&] { write_demo_file(path("demos.h5"), f); }),
                HasSubstr("data/demo_4: obs has 5 columns but data/demo_0's has 4"));
  }
  {
    DemoFile f = make_file();
    f.valid.push_back(5);
    EXPECT_THAT(error_of<std::invalid_argument>([&] { write_demo_file(path("demos.h5"), f); }),
                HasSubstr("mask/valid references demo 5, which does not exist"));
  }
  {
    DemoFile f = make_file();
    f.valid.push_back(f.train.front());
    EXPECT_THAT(error_of<std::invalid_argument>([&] { write_demo_file(path("demos.h5"), f); }),
                HasSubstr("is in both mask/train and mask/valid"));
  }
  {
    DemoFile f = make_file();
    f.demos[0].task = "gravity/1.5";
    EXPECT_THAT(error_of<std::invalid_argument>([&] { write_demo_file(path("demos.h5"), f); }),
                HasSubstr("data/demo_0: task 'gravity/1.5' differs from task_names[0] = 'gravity/0.5'"));
  }
  {
    DemoFile f = make_file();
    f.extra_json = "{not json";
    EXPECT_THAT(error_of<std::invalid_argument>([&] { write_demo_file(path("demos.h5"), f); }),
                HasSubstr("extra_json is not valid JSON"));
  }
  EXPECT_TRUE(listing().empty());
}

TEST_F(DemoFileTest, WriteIsAtomic) {
  const DemoFile first = make_file(3), second = make_file(5);
  write_demo_file(path("demos.h5"), first);
  EXPECT_EQ(listing(), std::vector<std::string>{"demos.h5"});
  // Overwriting replaces the file whole and leaves no temporary behind.
  write_demo_file(path("demos.h5"), second);
  EXPECT_EQ(listing(), std::vector<std::string>{"demos.h5"});
  EXPECT_EQ(read_demo_file(path("demos.h5")).demos.size(), 5u);
  // A write whose final rename fails (the destination is a non-empty folder) removes
  // its temporary and leaves the folder as it was.
  fs::create_directories(dir_ / "folder.h5" / "inside");
  EXPECT_THROW(write_demo_file(path("folder.h5"), first), std::runtime_error);
  std::set<std::string> names;
  for (const auto& name : listing()) names.insert(name);
  EXPECT_EQ(names, (std::set<std::string>{"demos.h5", "folder.h5"}));
  // A destination folder that does not exist: error naming the file, nothing created.
  const std::string msg = error_of([&] { write_demo_file(path("missing/demos.h5"), first); });
  EXPECT_THAT(msg, HasSubstr("missing"));
  EXPECT_FALSE(fs::exists(dir_ / "missing"));
}

}  // namespace
}  // namespace maps::envs
