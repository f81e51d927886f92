#include "autograd/matmul_precision.h"

#include <stdexcept>

#include "autograd/gemm_bf16.h"

namespace maps::ag {
namespace {
thread_local MatmulPrecision current = MatmulPrecision::float32;
}  // namespace

std::string to_string(MatmulPrecision precision) { return precision == MatmulPrecision::bf16 ? "bf16" : "float32"; }

const std::vector<std::string>& matmul_precision_names() {
  static const std::vector<std::string> names{"float32", "bf16"};
  return names;
}

MatmulPrecision parse_matmul_precision(const std::string& name) {
  if (name == "float32") return MatmulPrecision::float32;
  if (name == "bf16") return MatmulPrecision::bf16;
  throw std::invalid_argument("matmul precision '" + name + "': expected one of float32, bf16");
}

std::string matmul_precision_missing(MatmulPrecision precision) {
  if (precision == MatmulPrecision::float32 || detail::cpu_has_avx512_bf16()) return "";
  return detail::avx512_bf16_missing();
}

std::string matmul_precision_refusal(MatmulPrecision precision, const std::string& cpu) {
  const std::string missing = matmul_precision_missing(precision);
  if (missing.empty()) return "";
  return "needs a CPU with AVX512-BF16, and this one " + (cpu.empty() ? "" : "(" + cpu + ") ") + "lacks " + missing;
}

MatmulPrecision set_matmul_precision(MatmulPrecision precision) {
  if (const std::string refusal = matmul_precision_refusal(precision); !refusal.empty())
    throw std::runtime_error("matrix products in " + to_string(precision) + " " + refusal + " (use float32)");
  const MatmulPrecision previous = current;
  current = precision;
  return previous;
}

MatmulPrecision matmul_precision() { return current; }

}  // namespace maps::ag
