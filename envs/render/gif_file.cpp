#include "envs/render/gif_file.h"

#include <gif_lib.h>

#include <cstdio>
#include <filesystem>
#include <memory>
#include <stdexcept>

#include "io/atomic_file.h"

namespace maps::envs {
namespace {

// Closes the GIF (and with it the file) however writing ends.
struct GifCloser {
  void operator()(GifFileType* gif) const {
    int error = 0;
    EGifCloseFile(gif, &error);
  }
};

void check(int status, GifFileType* gif, const std::string& path, const char* what) {
  if (status != GIF_OK)
    throw std::runtime_error("writing the GIF '" + path + "' failed (" + what + ": " + GifErrorString(gif->Error) +
                             ")");
}

void write_frames(GifFileType* gif, const std::string& path, const std::vector<Image>& frames, int delay) {
  const int width = frames.front().width, height = frames.front().height;
  check(EGifPutScreenDesc(gif, width, height, 8, 0, nullptr), gif, path, "screen");
  // NETSCAPE2.0: loop forever.
  const unsigned char loop[3] = {1, 0, 0};
  check(EGifPutExtensionLeader(gif, APPLICATION_EXT_FUNC_CODE), gif, path, "loop");
  check(EGifPutExtensionBlock(gif, 11, "NETSCAPE2.0"), gif, path, "loop");
  check(EGifPutExtensionBlock(gif, 3, loop), gif, path, "loop");
  check(EGifPutExtensionTrailer(gif), gif, path, "loop");
  const std::size_t pixels = static_cast<std::size_t>(width) * height;
  std::vector<GifByteType> red(pixels), green(pixels), blue(pixels), indices(pixels);
  for (const Image& frame : frames) {
    for (std::size_t i = 0; i < pixels; ++i) {
      red[i] = frame.rgb[3 * i];
      green[i] = frame.rgb[3 * i + 1];
      blue[i] = frame.rgb[3 * i + 2];
    }
    int colours = 256;
    GifColorType palette[256];
    if (GifQuantizeBuffer(width, height, &colours, red.data(), green.data(), blue.data(), indices.data(), palette) !=
        GIF_OK)
      throw std::runtime_error("writing the GIF '" + path + "' failed (quantising a frame)");
    GraphicsControlBlock control{};
    control.DisposalMode = DISPOSE_DO_NOT;
    control.DelayTime = delay;
    control.TransparentColor = NO_TRANSPARENT_COLOR;
    GifByteType extension[4];
    EGifGCBToExtension(&control, extension);
    check(EGifPutExtension(gif, GRAPHICS_EXT_FUNC_CODE, 4, extension), gif, path, "frame delay");
    ColorMapObject* map = GifMakeMapObject(256, palette);
    if (map == nullptr) throw std::runtime_error("writing the GIF '" + path + "' failed (out of memory)");
    const int status = EGifPutImageDesc(gif, 0, 0, width, height, false, map);
    GifFreeMapObject(map);
    check(status, gif, path, "frame");
    for (int row = 0; row < height; ++row)
      check(EGifPutLine(gif, indices.data() + static_cast<std::size_t>(row) * width, width), gif, path, "pixels");
  }
}

}  // namespace

void write_gif(const std::string& path, const std::vector<Image>& frames, int delay_centiseconds) {
  if (frames.empty()) throw std::invalid_argument("write_gif " + path + ": no frames");
  if (delay_centiseconds < 1 || delay_centiseconds > 65535)
    throw std::invalid_argument("write_gif " + path + ": the delay must be 1 to 65535 centiseconds");
  for (const Image& frame : frames)
    if (frame.width != frames.front().width || frame.height != frames.front().height || frame.width < 1 ||
        frame.height < 1 || frame.rgb.size() != static_cast<std::size_t>(frame.width) * frame.height * 3)
      throw std::invalid_argument("write_gif " + path +
                                  ": the frames differ in size, or a size and its pixels "
                                  "disagree");
  io::write_through_temporary(
      path,
      [&](const std::string& temporary) {
        int error = 0;
        std::unique_ptr<GifFileType, GifCloser> gif(EGifOpenFileName(temporary.c_str(), false, &error));
        if (!gif)
          throw std::runtime_error("cannot open '" + temporary + "' to write the GIF '" + path + "' (" +
                                   GifErrorString(error) + ")");
        EGifSetGifVersion(gif.get(), true);
        write_frames(gif.get(), path, frames, delay_centiseconds);
        int close_error = 0;
        if (EGifCloseFile(gif.release(), &close_error) != GIF_OK)
          throw std::runtime_error("writing the GIF '" + path + "' failed (" + GifErrorString(close_error) + ")");
        // giflib creates its file readable by its owner only; a picture is for everyone, as write_png's are.
        namespace fs = std::filesystem;
        fs::permissions(
            temporary, fs::perms::owner_read | fs::perms::owner_write | fs::perms::group_read | fs::perms::others_read);
      },
      "GIF");
}

}  // namespace maps::envs
