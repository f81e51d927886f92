#pragma once

#include <cstddef>

// Tensor storage is recycled: a training step frees and asks again for the same sizes every step, and fresh
// large blocks from the system come as zeroed pages, faulted in one by one (measured: about 6% of a MAPS training
// step before the pool). Blocks are kept by exact size up to a cap and handed back to the system beyond it.
// Sanitizer builds bypass the pool so that use-after-free is still caught.
namespace maps::ag::detail {

// 64-byte aligned memory of `bytes` (a multiple of 64, > 0); throws std::bad_alloc.
void* pool_allocate(std::size_t bytes);
// Gives back a block from pool_allocate of the same size.
void pool_release(void* data, std::size_t bytes) noexcept;
// Bytes held for reuse (for tests).
std::size_t pool_cached_bytes();
// False in AddressSanitizer builds (gcc's or clang's), where every block goes straight back to the system.
bool pool_enabled();

}  // namespace maps::ag::detail
