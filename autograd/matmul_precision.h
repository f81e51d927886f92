#pragma once

// The precision of float32 matrix products (issue 44): float32 throughout, or bfloat16 products with float32 sums
// on CPUs with AVX512-BF16 (the usual mixed-precision recipe: the operands of each product rounded to bfloat16, the
// sums, the parameters, the optimiser's state, the losses and every other op in float32). float64 products (the
// gradient checks) are never rounded. The setting is per thread, as flushing denormals is (float_environment.h):
// the ops a thread runs follow it on any number of threads; a new thread starts in float32.
#include <string>
#include <vector>

namespace maps::ag {

enum class MatmulPrecision { float32, bf16 };

// "float32" or "bf16": the names a run config and `maps bench step --precision` take.
std::string to_string(MatmulPrecision precision);
const std::vector<std::string>& matmul_precision_names();
// Throws std::invalid_argument naming the value and the choices.
MatmulPrecision parse_matmul_precision(const std::string& name);

// What this build and CPU lack to run `precision` ("" when nothing: float32 always runs).
std::string matmul_precision_missing(MatmulPrecision precision);
// "" when this CPU runs `precision`, otherwise the reason as one phrase for a caller to put after the setting's name:
// "needs a CPU with AVX512-BF16, and this one (<cpu>) lacks <what>" (the parenthesis only when `cpu` is given).
std::string matmul_precision_refusal(MatmulPrecision precision, const std::string& cpu = "");

// Sets the calling thread's precision and returns the previous one. Throws std::runtime_error, naming what the CPU
// lacks, for a precision it cannot run (so no instruction it lacks is ever reached).
MatmulPrecision set_matmul_precision(MatmulPrecision precision);
MatmulPrecision matmul_precision();

// Sets the precision for its lifetime, then restores the one it found.
class MatmulPrecisionGuard {
 public:
  explicit MatmulPrecisionGuard(MatmulPrecision precision) : previous_(set_matmul_precision(precision)) {}
  ~MatmulPrecisionGuard() { set_matmul_precision(previous_); }
  MatmulPrecisionGuard(const MatmulPrecisionGuard&) = delete;
  MatmulPrecisionGuard& operator=(const MatmulPrecisionGuard&) = delete;

 private:
  MatmulPrecision previous_;
};

}  // namespace maps::ag
