#include "envs/render/offscreen_renderer.h"

#include <GL/osmesa.h>
#include <dlfcn.h>
#include <png.h>

#include <algorithm>
#include <cstdio>
#include <memory>
#include <mutex>
#include <stdexcept>

namespace maps::envs {
namespace {

// OSMesa is opened when the first renderer is made, not linked: it brings libLLVM, whose relocations cost every
// start of the maps tool about 80 ms (measured on an AMD EPYC VM), which the tests and the suite pay thousands of
// times and only `maps render` needs. RTLD_GLOBAL: MuJoCo's OpenGL loader finds OSMesaGetProcAddress by name.
struct OSMesaFunctions {
  decltype(&OSMesaCreateContextExt) create_context = nullptr;
  decltype(&OSMesaMakeCurrent) make_current = nullptr;
  decltype(&OSMesaDestroyContext) destroy_context = nullptr;
};

const OSMesaFunctions& osmesa() {
  static OSMesaFunctions functions;
  static std::string error;
  static std::once_flag opened;
  std::call_once(opened, [] {
    void* library = dlopen(MAPS_OSMESA_SONAME, RTLD_NOW | RTLD_GLOBAL);
    if (!library) {
      const char* why = dlerror();
      error = std::string("OffscreenRenderer: cannot open OSMesa (" MAPS_OSMESA_SONAME ", package libosmesa6): ") +
              (why ? why : "unknown error");
      return;
    }
    functions.create_context =
        reinterpret_cast<decltype(&OSMesaCreateContextExt)>(dlsym(library, "OSMesaCreateContextExt"));
    functions.make_current = reinterpret_cast<decltype(&OSMesaMakeCurrent)>(dlsym(library, "OSMesaMakeCurrent"));
    functions.destroy_context =
        reinterpret_cast<decltype(&OSMesaDestroyContext)>(dlsym(library, "OSMesaDestroyContext"));
    if (!functions.create_context || !functions.make_current || !functions.destroy_context) {
      functions = {};
      error = "OffscreenRenderer: " MAPS_OSMESA_SONAME
              " lacks OSMesaCreateContextExt, OSMesaMakeCurrent or "
              "OSMesaDestroyContext";
    }
  });
  if (!error.empty()) throw std::runtime_error(error);
  return functions;
}

}  // namespace

struct OffscreenRenderer::Impl {
  const mjModel* model = nullptr;
  int width = 0, height = 0;
  OSMesaContext context = nullptr;
  std::vector<std::uint8_t> buffer;  // OSMesa's colour buffer (RGBA)
  mjvScene scene;
  mjrContext render_context;
  mjvOption option;
  bool scene_made = false, render_context_made = false;

  ~Impl() {
    if (render_context_made) mjr_freeContext(&render_context);
    if (scene_made) mjv_freeScene(&scene);
    if (context) osmesa().destroy_context(context);
  }
};

OffscreenRenderer::OffscreenRenderer(const mjModel* model, int width, int height) {
  if (!model) throw std::invalid_argument("OffscreenRenderer: no model");
  if (width < 1 || height < 1 || width > model->vis.global.offwidth || height > model->vis.global.offheight) {
    throw std::invalid_argument("OffscreenRenderer: size " + std::to_string(width) + " x " + std::to_string(height) +
                                " must be positive and within the model's offscreen buffer " +
                                std::to_string(model->vis.global.offwidth) + " x " +
                                std::to_string(model->vis.global.offheight) + " (visual/global offwidth, offheight)");
  }
  auto impl = std::make_unique<Impl>();
  impl->model = model;
  impl->width = width;
  impl->height = height;
  impl->context = osmesa().create_context(OSMESA_RGBA, 24, 8, 0, nullptr);
  if (!impl->context) throw std::runtime_error("OffscreenRenderer: OSMesaCreateContextExt failed");
  // OSMesa draws into this buffer; MuJoCo's offscreen framebuffer lives in the same context.
  const int buffer_width = model->vis.global.offwidth, buffer_height = model->vis.global.offheight;
  impl->buffer.resize(static_cast<std::size_t>(buffer_width) * buffer_height * 4);
  if (!osmesa().make_current(impl->context, impl->buffer.data(), GL_UNSIGNED_BYTE, buffer_width, buffer_height))
    throw std::runtime_error("OffscreenRenderer: OSMesaMakeCurrent failed");
  mjv_defaultScene(&impl->scene);
  mjv_makeScene(model, &impl->scene, 2000);
  impl->scene_made = true;
  mjr_defaultContext(&impl->render_context);
  mjr_makeContext(model, &impl->render_context, mjFONTSCALE_100);
  impl->render_context_made = true;
  mjr_setBuffer(mjFB_OFFSCREEN, &impl->render_context);
  if (impl->render_context.currentBuffer != mjFB_OFFSCREEN)
    throw std::runtime_error("OffscreenRenderer: MuJoCo's offscreen framebuffer is not available");
  mjv_defaultOption(&impl->option);
  impl_ = impl.release();
}

OffscreenRenderer::~OffscreenRenderer() { delete impl_; }

Image OffscreenRenderer::render(const mjData* data, const CameraView& view) {
  const mjModel* m = impl_->model;
  mjvCamera camera;
  mjv_defaultCamera(&camera);
  if (!view.camera.empty()) {
    const int id = mj_name2id(m, mjOBJ_CAMERA, view.camera.c_str());
    if (id < 0) throw std::invalid_argument("OffscreenRenderer: the model has no camera named '" + view.camera + "'");
    camera.type = mjCAMERA_FIXED;
    camera.fixedcamid = id;
  } else {
    camera.type = mjCAMERA_FREE;
    for (int i = 0; i < 3; ++i) camera.lookat[i] = view.lookat[i];
    camera.distance = view.distance;
    camera.azimuth = view.azimuth;
    camera.elevation = view.elevation;
  }
  osmesa().make_current(impl_->context, impl_->buffer.data(), GL_UNSIGNED_BYTE, m->vis.global.offwidth,
                        m->vis.global.offheight);
  mjv_updateScene(m, const_cast<mjData*>(data), &impl_->option, nullptr, &camera, mjCAT_ALL, &impl_->scene);
  const mjrRect viewport{0, 0, impl_->width, impl_->height};
  mjr_render(viewport, &impl_->scene, &impl_->render_context);
  Image image;
  image.width = impl_->width;
  image.height = impl_->height;
  std::vector<std::uint8_t> bottom_up(static_cast<std::size_t>(image.width) * image.height * 3);
  mjr_readPixels(bottom_up.data(), nullptr, viewport, &impl_->render_context);
  // OpenGL's rows run bottom-up; PNG's top-down.
  image.rgb.resize(bottom_up.size());
  const std::size_t row = static_cast<std::size_t>(image.width) * 3;
  for (int y = 0; y < image.height; ++y)
    std::copy_n(bottom_up.data() + (image.height - 1 - y) * row, row, image.rgb.data() + y * row);
  return image;
}

void write_png(const std::string& path, const Image& image) {
  if (image.rgb.size() != static_cast<std::size_t>(image.width) * image.height * 3 || image.width < 1)
    throw std::invalid_argument("write_png " + path + ": the image's size and pixels disagree");
  std::unique_ptr<FILE, int (*)(FILE*)> file(std::fopen(path.c_str(), "wb"), &std::fclose);
  if (!file) throw std::runtime_error("cannot open '" + path + "' for writing");
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png ? png_create_info_struct(png) : nullptr;
  if (!png || !info || setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    throw std::runtime_error("writing the PNG '" + path + "' failed");
  }
  png_init_io(png, file.get());
  png_set_IHDR(png, info, image.width, image.height, 8, PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE,
               PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  for (int y = 0; y < image.height; ++y)
    png_write_row(png, const_cast<png_bytep>(image.rgb.data() + static_cast<std::size_t>(y) * image.width * 3));
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  if (std::fflush(file.get()) != 0) throw std::runtime_error("writing the PNG '" + path + "' failed");
}

}  // namespace maps::envs
