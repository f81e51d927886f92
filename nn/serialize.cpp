#include "nn/serialize.h"

#include <algorithm>
#include <bit>
#include <cerrno>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <stdexcept>
#include <unordered_set>

#include "io/atomic_file.h"

namespace maps::nn {

static_assert(std::endian::native == std::endian::little, "checkpoint files are written little-endian");

namespace {

constexpr char kMagic[8] = {'M', 'A', 'P', 'S', 'C', 'K', 'P', 'T'};
constexpr std::uint32_t kVersion = 1;
constexpr std::size_t kHeaderSize = 8 + 4 + 4 + 8;
constexpr std::size_t kMaxRank = 16;

std::uint64_t fnv1a64(const char* data, std::size_t size) {
  std::uint64_t h = 0xcbf29ce484222325ULL;
  for (std::size_t i = 0; i < size; ++i) {
    h ^= static_cast<unsigned char>(data[i]);
    h *= 0x100000001b3ULL;
  }
  return h;
}

std::runtime_error file_error(const std::string& path, const std::string& what) {
  return std::runtime_error("checkpoint " + path + ": " + what);
}

template <typename T>
void put(std::string& out, T value) {
  out.append(reinterpret_cast<const char*>(&value), sizeof(T));
}

// Bounds-checked reads over the loaded bytes; every failure names the file and the field.
class Reader {
 public:
  Reader(const std::string& path, const std::string& bytes, std::size_t begin, std::size_t end)
      : path_(path), bytes_(bytes), pos_(begin), end_(end) {}

  void need(std::size_t n, const std::string& what) const {
    if (n > end_ - pos_)
      throw file_error(path_, "truncated or corrupt: " + what + " needs " + std::to_string(n) + " bytes at offset " +
                                  std::to_string(pos_) + ", only " + std::to_string(end_ - pos_) + " remain");
  }
  template <typename T>
  T get(const std::string& what) {
    need(sizeof(T), what);
    T value;
    std::memcpy(&value, bytes_.data() + pos_, sizeof(T));
    pos_ += sizeof(T);
    return value;
  }
  std::string get_string(std::size_t n, const std::string& what) {
    need(n, what);
    std::string s = bytes_.substr(pos_, n);
    pos_ += n;
    return s;
  }
  void get_bytes(void* dst, std::size_t n, const std::string& what) {
    need(n, what);
    if (n > 0) std::memcpy(dst, bytes_.data() + pos_, n);
    pos_ += n;
  }
  std::size_t pos() const { return pos_; }
  std::size_t remaining() const { return end_ - pos_; }

 private:
  const std::string& path_;
  const std::string& bytes_;
  std::size_t pos_;
  std::size_t end_;
};

std::string encode(const NamedTensors& tensors, const std::string& config) {
  std::string payload;
  put<std::uint64_t>(payload, config.size());
  payload += config;
  put<std::uint64_t>(payload, tensors.size());
  std::unordered_set<std::string> seen;
  for (const auto& e : tensors) {
    if (e.name.empty()) throw std::invalid_argument("save_tensors: a tensor has an empty name");
    if (!seen.insert(e.name).second) throw std::invalid_argument("save_tensors: name \"" + e.name + "\" appears twice");
    if (!e.tensor.defined()) throw std::invalid_argument("save_tensors: tensor \"" + e.name + "\" is undefined");
    if (e.name.size() > UINT32_MAX) throw std::invalid_argument("save_tensors: name too long");
    if (static_cast<std::size_t>(e.tensor.dim()) > kMaxRank)
      throw std::invalid_argument("save_tensors: tensor \"" + e.name + "\" has more than 16 dims");
    put<std::uint32_t>(payload, static_cast<std::uint32_t>(e.name.size()));
    payload += e.name;
    put<std::uint8_t>(payload, e.tensor.dtype() == ag::Dtype::Float32 ? 1 : 2);
    put<std::uint8_t>(payload, static_cast<std::uint8_t>(e.tensor.dim()));
    for (std::int64_t d : e.tensor.shape()) put<std::int64_t>(payload, d);
    const std::size_t bytes = static_cast<std::size_t>(e.tensor.numel()) * ag::element_size(e.tensor.dtype());
    ag::dispatch_dtype(e.tensor.dtype(), [&](auto tag) {
      using T = typename decltype(tag)::type;
      payload.append(reinterpret_cast<const char*>(e.tensor.data<T>()), bytes);
    });
  }
  std::string file(kMagic, sizeof(kMagic));
  put<std::uint32_t>(file, kVersion);
  put<std::uint32_t>(file, 0);
  put<std::uint64_t>(file, payload.size());
  file += payload;
  put<std::uint64_t>(file, fnv1a64(payload.data(), payload.size()));
  return file;
}

}  // namespace

void save_tensors(const std::string& path, const NamedTensors& tensors, const std::string& config) {
  io::write_file_atomically(path, encode(tensors, config), "checkpoint");
}

Checkpoint load_tensors(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw file_error(path, std::string("cannot open: ") + std::strerror(errno));
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) throw file_error(path, "read error");

  // A file shorter than the magic is "bad magic" unless what it holds is the start of it.
  if (std::memcmp(bytes.data(), kMagic, std::min(bytes.size(), sizeof(kMagic))) != 0)
    throw file_error(path, "bad magic: not a maps checkpoint file");
  if (bytes.size() < kHeaderSize)
    throw file_error(path, "truncated: " + std::to_string(bytes.size()) + " bytes, shorter than the " +
                               std::to_string(kHeaderSize) + "-byte header");
  Reader header(path, bytes, sizeof(kMagic), bytes.size());
  const auto version = header.get<std::uint32_t>("version");
  if (version != kVersion)
    throw file_error(path, "unsupported version " + std::to_string(version) + " (this build reads version " +
                               std::to_string(kVersion) + ")");
  header.get<std::uint32_t>("reserved field");
  const auto payload_size = header.get<std::uint64_t>("payload size");
  const std::uint64_t expected = kHeaderSize + payload_size + sizeof(std::uint64_t);
  if (payload_size > bytes.size() || bytes.size() < expected)
    throw file_error(path, "truncated: the header announces " + std::to_string(expected) + " bytes, the file has " +
                               std::to_string(bytes.size()));
  if (bytes.size() > expected)
    throw file_error(path,
                     "corrupt: " + std::to_string(bytes.size() - expected) + " unexpected bytes after the checksum");
  std::uint64_t stored;
  std::memcpy(&stored, bytes.data() + kHeaderSize + payload_size, sizeof(stored));
  const std::uint64_t computed = fnv1a64(bytes.data() + kHeaderSize, payload_size);
  if (stored != computed) throw file_error(path, "checksum mismatch: the file is damaged");

  Reader r(path, bytes, kHeaderSize, kHeaderSize + payload_size);
  Checkpoint cp;
  const auto config_size = r.get<std::uint64_t>("config size");
  cp.config = r.get_string(static_cast<std::size_t>(config_size), "config");
  const auto count = r.get<std::uint64_t>("tensor count");
  std::unordered_set<std::string> seen;
  for (std::uint64_t k = 0; k < count; ++k) {
    const std::string at = "tensor " + std::to_string(k);
    const auto name_size = r.get<std::uint32_t>(at + " name size");
    std::string name = r.get_string(name_size, at + " name");
    if (name.empty()) throw file_error(path, at + " has an empty name");
    if (!seen.insert(name).second) throw file_error(path, "tensor \"" + name + "\" appears twice");
    const std::string of = "tensor \"" + name + "\"";
    const auto dtype_code = r.get<std::uint8_t>(of + " dtype");
    if (dtype_code != 1 && dtype_code != 2)
      throw file_error(path, of + " has unknown dtype code " + std::to_string(dtype_code));
    const ag::Dtype dtype = dtype_code == 1 ? ag::Dtype::Float32 : ag::Dtype::Float64;
    const auto rank = r.get<std::uint8_t>(of + " rank");
    if (rank > kMaxRank) throw file_error(path, of + " has rank " + std::to_string(rank) + " (at most 16)");
    ag::Shape shape(rank);
    std::uint64_t numel = 1;
    for (auto& d : shape) {
      d = r.get<std::int64_t>(of + " shape");
      if (d < 0) throw file_error(path, of + " has a negative dim " + std::to_string(d));
      if (d > 0 && numel > r.remaining() / static_cast<std::uint64_t>(d))
        throw file_error(path, "truncated or corrupt: " + of + " shape " + ag::to_string(shape) +
                                   " is larger than the rest of the file");
      numel *= static_cast<std::uint64_t>(d);
    }
    const std::uint64_t data_bytes = numel * ag::element_size(dtype);
    r.need(data_bytes, of + " values");
    ag::Tensor t = ag::zeros(shape, dtype);
    ag::dispatch_dtype(dtype, [&](auto tag) {
      using T = typename decltype(tag)::type;
      r.get_bytes(t.data<T>(), data_bytes, of + " values");
    });
    cp.tensors.push_back({std::move(name), std::move(t)});
  }
  if (r.remaining() != 0)
    throw file_error(path, "corrupt: " + std::to_string(r.remaining()) + " unread bytes after the last tensor");
  return cp;
}

void save(const Module& module, const std::string& path, const std::string& config) {
  save_tensors(path, module.state_dict(), config);
}

std::string load(Module& module, const std::string& path) {
  Checkpoint cp = load_tensors(path);
  try {
    module.load_state_dict(cp.tensors);
  } catch (const std::invalid_argument& e) {
    throw file_error(path, e.what());
  }
  return std::move(cp.config);
}

void append_with_prefix(NamedTensors& out, const NamedTensors& tensors, const std::string& prefix) {
  for (const auto& t : tensors) out.push_back({prefix + t.name, t.tensor});
}

NamedTensors strip_prefix(const NamedTensors& tensors, const std::string& prefix) {
  NamedTensors out;
  for (const auto& t : tensors)
    if (t.name.rfind(prefix, 0) == 0) out.push_back({t.name.substr(prefix.size()), t.tensor});
  return out;
}

}  // namespace maps::nn
