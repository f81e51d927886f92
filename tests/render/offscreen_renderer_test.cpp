#include "envs/render/offscreen_renderer.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <png.h>

#include <cstdio>
#include <filesystem>
#include <memory>
#include <set>
#include <stdexcept>

#include "envs/mujoco_env.h"
#include "envs/task_sets.h"

namespace maps::envs {
namespace {

using ::testing::HasSubstr;

Image read_png(const std::string& path) {
  png_image png{};
  png.version = PNG_IMAGE_VERSION;
  if (!png_image_begin_read_from_file(&png, path.c_str())) throw std::runtime_error(png.message);
  png.format = PNG_FORMAT_RGB;
  Image image;
  image.width = static_cast<int>(png.width);
  image.height = static_cast<int>(png.height);
  image.rgb.resize(PNG_IMAGE_SIZE(png));
  if (!png_image_finish_read(&png, nullptr, image.rgb.data(), 0, nullptr)) throw std::runtime_error(png.message);
  return image;
}

MujocoEnv& as_mujoco(Env& env) { return dynamic_cast<MujocoEnv&>(env); }

TEST(OffscreenRenderer, DrawsTheSceneAndThePngRoundTrips) {
  auto env = make_env("mt10/door-open");
  env->reset(0);
  OffscreenRenderer renderer(as_mujoco(*env).model(), 160, 120);
  CameraView view;
  view.lookat[1] = 0.7;
  view.distance = 1.2;
  const Image image = renderer.render(as_mujoco(*env).data(), view);
  ASSERT_EQ(image.width, 160);
  ASSERT_EQ(image.height, 120);
  ASSERT_EQ(image.rgb.size(), 160u * 120u * 3u);
  // Not a blank frame: many distinct colours.
  std::set<int> colours;
  for (std::size_t i = 0; i < image.rgb.size(); i += 3)
    colours.insert(image.rgb[i] << 16 | image.rgb[i + 1] << 8 | image.rgb[i + 2]);
  EXPECT_GT(colours.size(), 50u);

  const auto path = std::filesystem::temp_directory_path() / "maps_render_test.png";
  write_png(path.string(), image);
  const Image back = read_png(path.string());
  EXPECT_EQ(back.width, image.width);
  EXPECT_EQ(back.height, image.height);
  EXPECT_EQ(back.rgb, image.rgb);
  std::filesystem::remove(path);
}

TEST(OffscreenRenderer, SameStateSamePicture) {
  auto env = make_env("gravity/1.0");
  env->reset(3);
  OffscreenRenderer renderer(as_mujoco(*env).model(), 64, 48);
  const Image a = renderer.render(as_mujoco(*env).data(), CameraView{});
  const Image b = renderer.render(as_mujoco(*env).data(), CameraView{});
  EXPECT_EQ(a.rgb, b.rgb);
}

TEST(OffscreenRenderer, BadSizeCameraAndPathAreNamed) {
  auto env = make_env("mt10/reach");
  env->reset(0);
  EXPECT_THAT([&] { OffscreenRenderer(as_mujoco(*env).model(), 4000, 100); },
              ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("4000 x 100")));
  OffscreenRenderer renderer(as_mujoco(*env).model(), 32, 32);
  CameraView view;
  view.camera = "no_such_camera";
  EXPECT_THAT([&] { renderer.render(as_mujoco(*env).data(), view); },
              ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("no_such_camera")));
  view.camera = "corner";  // scene.xml's
  const Image image = renderer.render(as_mujoco(*env).data(), view);
  EXPECT_THAT([&] { write_png("/nonexistent-folder/x.png", image); },
              ::testing::ThrowsMessage<std::runtime_error>(HasSubstr("/nonexistent-folder/x.png")));
}

}  // namespace
}  // namespace maps::envs
