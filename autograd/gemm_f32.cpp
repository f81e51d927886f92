// Which float32 kernel runs: chosen at run time from what the build has and the CPU runs (autograd/gemm_f32.h).

#include "autograd/gemm_f32.h"

#include <atomic>
#include <cstdlib>
#include <mutex>
#include <new>
#include <stdexcept>

namespace maps::ag::detail {

namespace {

// Whether this build compiled each variant (autograd/CMakeLists.txt defines these where the compiler took the flags).
#ifndef MAPS_HAVE_F32_AVX512
#define MAPS_HAVE_F32_AVX512 0
#endif
#ifndef MAPS_HAVE_F32_AVX2
#define MAPS_HAVE_F32_AVX2 0
#endif

bool cpu_runs(F32Kernel kernel) {
#if (MAPS_HAVE_F32_AVX512 || MAPS_HAVE_F32_AVX2) && (defined(__GNUC__) || defined(__clang__))
  // __builtin_cpu_supports checks the OS saves the wide registers too (XGETBV), not only CPUID's bits.
  switch (kernel) {
    case F32Kernel::avx512:
      return __builtin_cpu_supports("avx512f");
    case F32Kernel::avx2:
      return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
    case F32Kernel::eigen:
      return true;
  }
  return false;
#else
  return kernel == F32Kernel::eigen;
#endif
}

bool build_has(F32Kernel kernel) {
  switch (kernel) {
    case F32Kernel::avx512:
      return MAPS_HAVE_F32_AVX512;
    case F32Kernel::avx2:
      return MAPS_HAVE_F32_AVX2;
    case F32Kernel::eigen:
      return true;
  }
  return false;
}

// -1 until decided; then the F32Kernel's value. Products read it once each (relaxed: the choice is made before any
// product and changed only between them, by tests and benchmarks).
std::atomic<int> chosen{-1};

F32Kernel from_environment() {
  const char* named = std::getenv("MAPS_F32_KERNEL");
  if (named == nullptr || *named == '\0') return best_f32_kernel();
  const F32Kernel kernel = parse_f32_kernel(named, "MAPS_F32_KERNEL");
  const std::string missing = f32_kernel_missing(kernel);
  if (!missing.empty()) throw std::runtime_error("MAPS_F32_KERNEL=" + std::string(named) + ": " + missing);
  return kernel;
}

}  // namespace

const char* f32_kernel_name(F32Kernel kernel) {
  switch (kernel) {
    case F32Kernel::avx512:
      return "maps AVX-512";
    case F32Kernel::avx2:
      return "maps AVX2";
    case F32Kernel::eigen:
      return "Eigen";
  }
  return "?";
}

const std::vector<std::string>& f32_kernel_choices() {
  static const std::vector<std::string> choices = {"avx512", "avx2", "eigen"};
  return choices;
}

F32Kernel parse_f32_kernel(const std::string& name, const std::string& where) {
  if (name == "avx512") return F32Kernel::avx512;
  if (name == "avx2") return F32Kernel::avx2;
  if (name == "eigen") return F32Kernel::eigen;
  throw std::invalid_argument(where + ": expected \"avx512\", \"avx2\" or \"eigen\", got \"" + name + "\"");
}

std::string f32_kernel_missing(F32Kernel kernel) {
  if (!build_has(kernel))
    return std::string("this build has no ") + f32_kernel_name(kernel) +
           " kernel (its compiler did not take the instruction set's flags, or the target is not x86-64)";
  if (!cpu_runs(kernel))
    return std::string("this CPU cannot run the ") + f32_kernel_name(kernel) + " kernel (it lacks " +
           (kernel == F32Kernel::avx512 ? "AVX-512F" : "AVX2 or FMA") + ")";
  return "";
}

F32Kernel best_f32_kernel() {
  for (const F32Kernel kernel : {F32Kernel::avx512, F32Kernel::avx2})
    if (f32_kernel_missing(kernel).empty()) return kernel;
  return F32Kernel::eigen;
}

F32Kernel f32_kernel() {
  int value = chosen.load(std::memory_order_relaxed);
  if (value < 0) {
    static std::mutex deciding;
    const std::lock_guard<std::mutex> lock(deciding);
    value = chosen.load(std::memory_order_relaxed);
    if (value < 0) {
      value = static_cast<int>(from_environment());
      chosen.store(value, std::memory_order_relaxed);
    }
  }
  return static_cast<F32Kernel>(value);
}

F32Kernel set_f32_kernel(F32Kernel kernel) {
  const std::string missing = f32_kernel_missing(kernel);
  if (!missing.empty())
    throw std::runtime_error(std::string("float32 kernel ") + f32_kernel_name(kernel) + ": " + missing);
  const F32Kernel previous = f32_kernel();
  chosen.store(static_cast<int>(kernel), std::memory_order_relaxed);
  return previous;
}

void gemm_f32(StridedF32 a, StridedF32 b, float* c, std::int64_t ldc, std::int64_t m, std::int64_t n, std::int64_t k,
              bool accumulate) {
  switch (f32_kernel()) {
#if MAPS_HAVE_F32_AVX512
    case F32Kernel::avx512:
      gemm_f32_avx512(a, b, c, ldc, m, n, k, accumulate);
      return;
#endif
#if MAPS_HAVE_F32_AVX2
    case F32Kernel::avx2:
      gemm_f32_avx2(a, b, c, ldc, m, n, k, accumulate);
      return;
#endif
    default:
      throw std::logic_error("gemm_f32: the float32 kernel in use is Eigen's (gemm_serial calls Eigen for it)");
  }
}

void f32_scratch_exhausted(std::int64_t floats) {
  (void)floats;
  throw std::bad_alloc();
}

}  // namespace maps::ag::detail
