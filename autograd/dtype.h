#pragma once

#include <cstddef>
#include <stdexcept>
#include <string>
#include <type_traits>

namespace maps::ag {

// Training runs in float32; gradient checks need float64's precision.
enum class Dtype { Float32, Float64 };

inline std::string to_string(Dtype dtype) { return dtype == Dtype::Float32 ? "float32" : "float64"; }

inline std::size_t element_size(Dtype dtype) { return dtype == Dtype::Float32 ? 4 : 8; }

template <typename T>
constexpr Dtype dtype_of() {
  static_assert(std::is_same_v<T, float> || std::is_same_v<T, double>, "only float and double tensors exist");
  return std::is_same_v<T, float> ? Dtype::Float32 : Dtype::Float64;
}

template <typename T>
struct TypeTag {
  using type = T;
};

// Calls fn(TypeTag<float>{}) or fn(TypeTag<double>{}) so kernels are written once as templates.
template <typename Fn>
decltype(auto) dispatch_dtype(Dtype dtype, Fn&& fn) {
  if (dtype == Dtype::Float32) return fn(TypeTag<float>{});
  return fn(TypeTag<double>{});
}

}  // namespace maps::ag
