#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace maps::ag {

using Shape = std::vector<std::int64_t>;

std::int64_t numel_of(const Shape& shape);
std::string to_string(const Shape& shape);

// NumPy broadcasting of two shapes; throws naming `op` and both shapes when they do not broadcast.
Shape broadcast_shapes(const Shape& a, const Shape& b, const char* op);

// Turns a possibly negative dim into [0, rank); throws naming `op` when it is out of range.
std::int64_t normalize_dim(std::int64_t dim, std::int64_t rank, const char* op);

// Row-major strides of a contiguous tensor of this shape.
std::vector<std::int64_t> contiguous_strides(const Shape& shape);

}  // namespace maps::ag
