#include "autograd/storage_pool.h"

#include <cstdlib>
#include <mutex>
#include <new>
#include <unordered_map>
#include <vector>

#if defined(__SANITIZE_ADDRESS__)
#define MAPS_STORAGE_POOL 0
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define MAPS_STORAGE_POOL 0
#endif
#endif
#ifndef MAPS_STORAGE_POOL
#define MAPS_STORAGE_POOL 1
#endif

namespace maps::ag::detail {
namespace {

constexpr std::size_t kAlignment = 64;
// Above a MAPS step's working set at the paper's shapes (tens of MB; the Modified set's largest), far below the
// machine's memory even with a grid's runs side by side. Blocks past the cap go back to the system.
constexpr std::size_t kMaxCachedBytes = std::size_t{256} << 20;

struct Pool {
  std::mutex mutex;
  std::unordered_map<std::size_t, std::vector<void*>> free_blocks;
  std::size_t cached = 0;

  ~Pool() {
    for (auto& [bytes, blocks] : free_blocks)
      for (void* block : blocks) std::free(block);
  }
};

Pool& pool() {
  static Pool* instance = new Pool;  // never destroyed: tensors in static objects may outlive any order
  return *instance;
}

}  // namespace

void* pool_allocate(std::size_t bytes) {
  if (MAPS_STORAGE_POOL) {
    Pool& p = pool();
    const std::lock_guard<std::mutex> lock(p.mutex);
    auto it = p.free_blocks.find(bytes);
    if (it != p.free_blocks.end() && !it->second.empty()) {
      void* block = it->second.back();
      it->second.pop_back();
      p.cached -= bytes;
      return block;
    }
  }
  void* block = std::aligned_alloc(kAlignment, bytes);
  if (block == nullptr) throw std::bad_alloc();
  return block;
}

void pool_release(void* data, std::size_t bytes) noexcept {
  if (data == nullptr) return;
  if (MAPS_STORAGE_POOL) {
    Pool& p = pool();
    const std::lock_guard<std::mutex> lock(p.mutex);
    if (p.cached + bytes <= kMaxCachedBytes) {
      try {
        p.free_blocks[bytes].push_back(data);
        p.cached += bytes;
        return;
      } catch (...) {  // no memory for the bookkeeping: give the block back instead
      }
    }
  }
  std::free(data);
}

bool pool_enabled() { return MAPS_STORAGE_POOL != 0; }

std::size_t pool_cached_bytes() {
  Pool& p = pool();
  const std::lock_guard<std::mutex> lock(p.mutex);
  return p.cached;
}

}  // namespace maps::ag::detail
