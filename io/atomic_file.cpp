#include "io/atomic_file.h"

#include <fcntl.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <stdexcept>

namespace maps::io {
namespace {

std::runtime_error file_error(const std::string& what, const std::string& path, const std::string& why) {
  return std::runtime_error(what + " " + path + ": " + why);
}

// Flushes the temporary's bytes to the disk before the rename makes them the file: after a crash the name never
// points at a file whose data did not reach the disk.
void sync_file(const std::string& what, const std::string& path, const std::string& temporary) {
  const int fd = ::open(temporary.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw file_error(what, path, "cannot reopen " + temporary + " to sync it: " + std::strerror(errno));
  const bool synced = ::fsync(fd) == 0;
  const int error = errno;
  ::close(fd);
  if (!synced) throw file_error(what, path, "fsync of " + temporary + " failed: " + std::strerror(error));
}

}  // namespace

std::string temporary_path_for(const std::string& path) {
  static std::atomic<std::uint64_t> counter{0};
  char host[64] = {};
  if (::gethostname(host, sizeof(host) - 1) != 0) host[0] = '\0';
  const std::filesystem::path target(path);
  std::string name = ".";
  name += target.filename().string();
  name += ".tmp-" + std::string(host) + "-" + std::to_string(::getpid()) + "-" + std::to_string(counter++);
  return (target.parent_path() / name).string();
}

void write_through_temporary(const std::string& path, const std::function<void(const std::string& temporary)>& write,
                             const std::string& what) {
  const std::string temporary = temporary_path_for(path);
  try {
    write(temporary);
    sync_file(what, path, temporary);
    if (::rename(temporary.c_str(), path.c_str()) != 0)
      throw file_error(what, path, "rename from " + temporary + " failed: " + std::strerror(errno));
  } catch (...) {
    ::unlink(temporary.c_str());
    throw;
  }
}

void write_file_atomically(const std::string& path, const std::string& bytes, const std::string& what) {
  write_through_temporary(
      path,
      [&](const std::string& temporary) {
        const int fd = ::open(temporary.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
        if (fd < 0)
          throw file_error(what, path, "cannot create temporary file " + temporary + ": " + std::strerror(errno));
        std::size_t written = 0;
        while (written < bytes.size()) {
          const ssize_t n = ::write(fd, bytes.data() + written, bytes.size() - written);
          if (n < 0 && errno == EINTR) continue;
          if (n < 0) {
            const int error = errno;
            ::close(fd);
            throw file_error(what, path, "write to " + temporary + " failed: " + std::strerror(error));
          }
          written += static_cast<std::size_t>(n);
        }
        if (::close(fd) != 0)
          throw file_error(what, path, "close of " + temporary + " failed: " + std::strerror(errno));
      },
      what);
}

}  // namespace maps::io
