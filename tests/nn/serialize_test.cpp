#include <filesystem>
#include <fstream>
#include <iterator>

#include "nn_test_util.h"
#include "tests/common/temp_folder.h"

namespace nntest {
namespace {

namespace fs = std::filesystem;

class Serialize : public TempFolderTest {
 protected:
  Serialize() : TempFolderTest("maps_nn_serialize_") {}

  static std::string read(const std::string& p) {
    std::ifstream in(p, std::ios::binary);
    return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  }
  static void write(const std::string& p, const std::string& bytes) {
    std::ofstream out(p, std::ios::binary | std::ios::trunc);
    out << bytes;
  }
};

std::shared_ptr<nn::MLP> make_mlp(std::uint64_t seed, std::vector<std::int64_t> sizes = {3, 5, 2}) {
  ag::Generator gen(seed);
  return std::make_shared<nn::MLP>(sizes, "tanh", gen);
}

TEST_F(Serialize, RoundTripIsExact) {
  auto a = make_mlp(81), b = make_mlp(82);
  const std::string config = R"({"sizes": [3, 5, 2], "activation": "tanh"})";
  nn::save(*a, path("model.ckpt"), config);
  EXPECT_EQ(nn::load(*b, path("model.ckpt")), config);
  const auto sa = a->state_dict(), sb = b->state_dict();
  ASSERT_EQ(sa.size(), sb.size());
  for (std::size_t i = 0; i < sa.size(); ++i) {
    EXPECT_EQ(sa[i].name, sb[i].name);
    EXPECT_EQ(sa[i].tensor.to_vector(), sb[i].tensor.to_vector()) << sa[i].name;
  }
  // No temporary file is left behind.
  EXPECT_EQ(std::distance(fs::directory_iterator(dir_), fs::directory_iterator()), 1);
}

TEST_F(Serialize, TensorsKeepDtypeShapeAndOrder) {
  nn::NamedTensors tensors = {{"b", tensor({1.0, 2.0, 3.0, 4.0, 5.0, 6.0}, {2, 1, 3})},
                              {"a", tensor({0.1f}, {}, Dtype::Float32)},
                              {"empty", ag::zeros({0, 4})}};
  nn::save_tensors(path("t.ckpt"), tensors);
  const nn::Checkpoint cp = nn::load_tensors(path("t.ckpt"));
  EXPECT_EQ(cp.config, "");
  ASSERT_EQ(cp.tensors.size(), 3u);
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(cp.tensors[i].name, tensors[i].name);
    EXPECT_EQ(cp.tensors[i].tensor.shape(), tensors[i].tensor.shape());
    EXPECT_EQ(cp.tensors[i].tensor.dtype(), tensors[i].tensor.dtype());
    EXPECT_EQ(cp.tensors[i].tensor.to_vector(), tensors[i].tensor.to_vector());
  }
  // Saving over an existing file replaces it.
  nn::save_tensors(path("t.ckpt"), {{"only", ag::ones({1})}}, "second");
  EXPECT_EQ(nn::load_tensors(path("t.ckpt")).config, "second");
}

TEST_F(Serialize, TruncatedFileIsRefused) {
  auto m = make_mlp(83);
  nn::save(*m, path("m.ckpt"));
  const std::string bytes = read(path("m.ckpt"));
  for (std::size_t keep : {std::size_t{0}, std::size_t{5}, std::size_t{20}, bytes.size() / 2, bytes.size() - 1}) {
    write(path("cut.ckpt"), bytes.substr(0, keep));
    const std::string msg = error_of([&] { nn::load(*m, path("cut.ckpt")); });
    EXPECT_THAT(msg, HasSubstr("cut.ckpt")) << keep;
    EXPECT_THAT(msg, HasSubstr("truncated")) << keep;
  }
  EXPECT_THAT(error_of([&] { nn::load_tensors(path("absent.ckpt")); }),
              ::testing::AllOf(HasSubstr("absent.ckpt"), HasSubstr("cannot open")));
}

TEST_F(Serialize, FlippedByteFailsTheChecksum) {
  auto m = make_mlp(84);
  nn::save(*m, path("m.ckpt"), "config");
  std::string bytes = read(path("m.ckpt"));
  bytes[bytes.size() / 2] ^= 0x10;
  write(path("m.ckpt"), bytes);
  const auto before = m->state_dict()[0].tensor.to_vector();
  EXPECT_THAT(error_of([&] { nn::load(*m, path("m.ckpt")); }),
              ::testing::AllOf(HasSubstr("m.ckpt"), HasSubstr("checksum mismatch")));
  EXPECT_EQ(m->state_dict()[0].tensor.to_vector(), before);
  // Extra bytes after the checksum are refused too.
  nn::save(*m, path("m.ckpt"));
  write(path("m.ckpt"), read(path("m.ckpt")) + "x");
  EXPECT_THAT(error_of([&] { nn::load(*m, path("m.ckpt")); }), HasSubstr("unexpected bytes"));
}

TEST_F(Serialize, WrongMagicAndVersionAreRefused) {
  write(path("text.ckpt"), "this is not a checkpoint at all, just some text");
  EXPECT_THAT(error_of([&] { nn::load_tensors(path("text.ckpt")); }),
              ::testing::AllOf(HasSubstr("text.ckpt"), HasSubstr("bad magic")));
  nn::save_tensors(path("v.ckpt"), {{"x", ag::ones({2})}});
  std::string bytes = read(path("v.ckpt"));
  bytes[8] = 7;  // the version field follows the 8-byte magic
  write(path("v.ckpt"), bytes);
  EXPECT_THAT(error_of([&] { nn::load_tensors(path("v.ckpt")); }), HasSubstr("unsupported version 7"));
}

TEST_F(Serialize, MismatchedModuleIsRefused) {
  auto small = make_mlp(85, {3, 5, 2});
  nn::save(*small, path("small.ckpt"));
  auto wide = make_mlp(86, {3, 6, 2});
  EXPECT_THAT(error_of([&] { nn::load(*wide, path("small.ckpt")); }),
              ::testing::AllOf(HasSubstr("small.ckpt"),
                               HasSubstr("layers.0.weight (expected [6, 3] float32, got [5, 3] float32)")));
  auto deeper = make_mlp(87, {3, 5, 5, 2});
  EXPECT_THAT(error_of([&] { nn::load(*deeper, path("small.ckpt")); }),
              HasSubstr("Missing: layers.2.weight, layers.2.bias"));
  ag::Generator gen(88);
  nn::Linear other(3, 5, gen);
  EXPECT_THAT(error_of([&] { nn::load(other, path("small.ckpt")); }),
              ::testing::AllOf(HasSubstr("Missing: weight, bias"), HasSubstr("Unexpected: layers.0.weight")));
  small->to(Dtype::Float64);
  EXPECT_THAT(error_of([&] { nn::load(*small, path("small.ckpt")); }), HasSubstr("got [5, 3] float32"));
}

TEST_F(Serialize, UnwritableFolderIsAnError) {
  EXPECT_THAT(error_of([&] {
                nn::save_tensors(path("no/such/dir/x.ckpt"), {{"x", ag::ones({1})}});
              }),
              ::testing::AllOf(HasSubstr("x.ckpt"), HasSubstr("cannot create temporary file")));
}

}  // namespace
}  // namespace nntest
