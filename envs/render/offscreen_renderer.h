#pragma once

#include <mujoco/mujoco.h>

#include <cstdint>
#include <string>
#include <vector>

// Offscreen pictures of a MuJoCo scene with MuJoCo's own renderer, on machines without a GPU or display: an OSMesa
// (software OpenGL) context, then mjr_makeContext and the offscreen framebuffer. An optional part of the build
// (target maps_render, when OSMesa and libpng are installed); nothing else depends on it.
namespace maps::envs {

// Where the picture is taken from: a camera of the model by name, or a free camera looking at `lookat`.
struct CameraView {
  std::string camera;  // a named camera of the model; empty: the free camera below
  double lookat[3] = {0.0, 0.0, 0.0};
  double distance = 2.0;
  double azimuth = 90.0;     // degrees
  double elevation = -20.0;  // degrees
};

struct Image {
  int width = 0;
  int height = 0;
  std::vector<std::uint8_t> rgb;  // row-major from the top row, 3 bytes a pixel
};

// One renderer per thread; the OpenGL context is current on the thread that made it.
class OffscreenRenderer {
 public:
  // width and height must not exceed the model's offscreen buffer (visual/global offwidth, offheight; default
  // 640 x 480); an error names both sizes.
  OffscreenRenderer(const mjModel* model, int width, int height);
  ~OffscreenRenderer();
  OffscreenRenderer(const OffscreenRenderer&) = delete;
  OffscreenRenderer& operator=(const OffscreenRenderer&) = delete;

  Image render(const mjData* data, const CameraView& view);

 private:
  struct Impl;
  Impl* impl_;
};

// Writes 8-bit RGB PNG (libpng); throws naming the file on failure.
void write_png(const std::string& path, const Image& image);

}  // namespace maps::envs
