#pragma once

// The matrix product kernel under gemm, matmul, linear and parallel_linear: on row-major blocks with leading
// dimensions, float32 runs maps's own kernel (gemm_f32.h) where the build has one, float64 and the rest Eigen's
// GEMM with the inner dimension summed in blocks; the output is split across the op threads. Internal to the
// autograd layer.

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <type_traits>

#include "autograd/gemm_bf16.h"
#include "autograd/gemm_f32.h"
#include "autograd/matmul_precision.h"
#include "autograd/parallel.h"
#include "autograd/tensor.h"

namespace maps::ag::detail {

// A row-major matrix stored with `ld` elements between the starts of consecutive rows.
template <typename T>
struct MatrixRef {
  T* data;
  std::int64_t rows, cols, ld;
};

template <typename T>
using StridedMap = Eigen::Map<RowMatrix<T>, 0, Eigen::OuterStride<>>;
template <typename T>
using ConstStridedMap = Eigen::Map<const RowMatrix<T>, 0, Eigen::OuterStride<>>;

// Eigen 3.4's blocking heuristic keeps the whole inner dimension as one block for small outputs, and for inner
// dimensions from about 384 to 1000 then runs at 40% of its speed, its packed panels no longer in L1 (measured on a
// [128, 128] output: X^T G at 62-70 GFLOP/s for k = 384..896, 144-147 in blocks of 256; k = 320 in one block ran
// at 150). A small output is re-read cheaply, so its products are summed in equal inner blocks of at most 320; a
// large output (the 1024^3 reference) is left to Eigen, whose own blocking does well there and loses 8% to the
// extra passes.
constexpr std::int64_t kInnerBlock = 320;
constexpr std::int64_t kInnerBlockedOutput = 256 * 256;

// A row-major output this narrow (a policy's 4-10 actions or modules) and at least this many times as tall is
// computed column-major and copied: Eigen fills a row-major output as the transposed product, whose left panels
// (48 rows per AVX-512 panel) would then hold only these few rows (measured, [640, 128] x [128, 6]: 23 us
// row-major, 14.5 us column-major and copied; [128, 640] x [640, 6]: 33.5 and 12.4 us; 16 columns and up: no gain).
constexpr std::int64_t kNarrowOutput = 12;
constexpr std::int64_t kNarrowAspect = 4;

// op(X) of a stored row-major X as strides.
inline StridedF32 op_strides(MatrixRef<const float> x, bool transposed) {
  return transposed ? StridedF32{x.data, 1, x.ld} : StridedF32{x.data, x.ld, 1};
}

// Under MatmulPrecision::bf16, a float32 product whose output has fewer columns than this stays float32: the
// bfloat16 kernel's tile is 32 columns wide, and on narrower outputs its packing costs more than its products save
// (measured, AMD EPYC Zen 5: [320, 128] x [128, 4] 25 GFLOP/s bf16 against 34 float32, [3520, 128] x [128, 10] 47
// against 85; 64 columns and up 1.45-1.95x float32's speed).
constexpr std::int64_t kBf16MinColumns = 16;

// The products' FLOPs (2 m n k each) while a GemmFlopCounter lives (ops.h); one relaxed load per product otherwise.
extern std::atomic<int> gemm_flop_counters;
extern std::atomic<std::uint64_t> gemm_flops_counted;

// C (=|+=) op(A) op(B), one thread. A and B as stored; op transposes when asked. float32 runs the own kernel
// (gemm_f32.h) chosen for the CPU, or Eigen's where none runs; float64 (gradient checks) Eigen's.
template <typename T>
void gemm_serial(MatrixRef<const T> a, bool ta, MatrixRef<const T> b, bool tb, MatrixRef<T> c, bool accumulate) {
  if (gemm_flop_counters.load(std::memory_order_relaxed) > 0)
    gemm_flops_counted.fetch_add(static_cast<std::uint64_t>(2 * c.rows * c.cols * (ta ? a.rows : a.cols)),
                                 std::memory_order_relaxed);
  if constexpr (std::is_same_v<T, float>) {
    if (c.cols >= kBf16MinColumns && matmul_precision() == MatmulPrecision::bf16) {
      gemm_bf16(op_strides(a, ta), op_strides(b, tb), c.data, c.ld, c.rows, c.cols, ta ? a.rows : a.cols, accumulate);
      return;
    }
  }
  if constexpr (std::is_same_v<T, float>) {
    if (f32_kernel() != F32Kernel::eigen) {
      gemm_f32(op_strides(a, ta), op_strides(b, tb), c.data, c.ld, c.rows, c.cols, ta ? a.rows : a.cols, accumulate);
      return;
    }
  }
  ConstStridedMap<T> ma(a.data, a.rows, a.cols, Eigen::OuterStride<>(a.ld));
  ConstStridedMap<T> mb(b.data, b.rows, b.cols, Eigen::OuterStride<>(b.ld));
  StridedMap<T> mc(c.data, c.rows, c.cols, Eigen::OuterStride<>(c.ld));
  const std::int64_t k = ta ? a.rows : a.cols;
  if (k == 0) {
    if (!accumulate) mc.setZero();
    return;
  }
  if (c.cols <= kNarrowOutput && c.rows >= kNarrowAspect * c.cols) {
    thread_local Eigen::Matrix<T, Eigen::Dynamic, Eigen::Dynamic> column_major;
    column_major.resize(c.rows, c.cols);
    auto run = [&](const auto& lhs, const auto& rhs) {
      column_major.noalias() = lhs * rhs;
      if (accumulate) {
        mc += column_major;
      } else {
        mc = column_major;
      }
    };
    if (!ta && !tb) {
      run(ma, mb);
    } else if (!ta && tb) {
      run(ma, mb.transpose());
    } else if (ta && !tb) {
      run(ma.transpose(), mb);
    } else {
      run(ma.transpose(), mb.transpose());
    }
    return;
  }
  // Equal blocks of at most kInnerBlock: an inner dimension of 320 stays one block, 640 makes two of 320.
  const std::int64_t blocks = c.rows * c.cols <= kInnerBlockedOutput ? (k + kInnerBlock - 1) / kInnerBlock : 1;
  const std::int64_t block = (k + blocks - 1) / blocks;
  for (std::int64_t start = 0; start < k; start += block) {
    const std::int64_t len = std::min(block, k - start);
    const bool add = accumulate || start > 0;
    auto run = [&](const auto& lhs, const auto& rhs) {
      if (add) {
        mc.noalias() += lhs * rhs;
      } else {
        mc.noalias() = lhs * rhs;
      }
    };
    if (!ta && !tb) {
      run(ma.middleCols(start, len), mb.middleRows(start, len));
    } else if (!ta && tb) {
      run(ma.middleCols(start, len), mb.middleCols(start, len).transpose());
    } else if (ta && !tb) {
      run(ma.middleRows(start, len).transpose(), mb.middleRows(start, len));
    } else {
      run(ma.middleRows(start, len).transpose(), mb.middleCols(start, len).transpose());
    }
  }
}

// Rows [r0, r1) of op(X) as a block of the stored X.
template <typename T>
MatrixRef<T> op_rows(MatrixRef<T> x, bool transposed, std::int64_t r0, std::int64_t r1) {
  return transposed ? MatrixRef<T>{x.data + r0, x.rows, r1 - r0, x.ld}
                    : MatrixRef<T>{x.data + r0 * x.ld, r1 - r0, x.cols, x.ld};
}

// Columns [c0, c1) of op(X) as a block of the stored X.
template <typename T>
MatrixRef<T> op_cols(MatrixRef<T> x, bool transposed, std::int64_t c0, std::int64_t c1) {
  return op_rows(x, !transposed, c0, c1);
}

// Products smaller than this (in multiply-adds) run on one thread: a split costs a few microseconds.
constexpr std::int64_t kParallelGemmWork = 1 << 18;

// gemm_serial, with the output split across the op threads: by rows when it has at least as many rows as
// columns, else by columns (each thread's block is a product of its own, reading shared inputs).
template <typename T>
void gemm_parallel(MatrixRef<const T> a, bool ta, MatrixRef<const T> b, bool tb, MatrixRef<T> c, bool accumulate) {
  const std::int64_t k = ta ? a.rows : a.cols;
  if (num_threads() <= 1 || c.rows * c.cols * std::max<std::int64_t>(k, 1) < kParallelGemmWork) {
    gemm_serial(a, ta, b, tb, c, accumulate);
    return;
  }
  // Split on multiples of 16 (one AVX-512 register of floats) so blocks keep Eigen's vector alignment of work.
  const bool by_rows = c.rows >= c.cols;
  const std::int64_t extent = by_rows ? c.rows : c.cols, units = (extent + 15) / 16;
  parallel_for(units, 1, [&](std::int64_t u0, std::int64_t u1) {
    const std::int64_t lo = u0 * 16, hi = std::min(extent, u1 * 16);
    if (by_rows) {
      gemm_serial(op_rows(a, ta, lo, hi), ta, b, tb, MatrixRef<T>{c.data + lo * c.ld, hi - lo, c.cols, c.ld},
                  accumulate);
    } else {
      gemm_serial(a, ta, op_cols(b, tb, lo, hi), tb, MatrixRef<T>{c.data + lo, c.rows, hi - lo, c.ld}, accumulate);
    }
  });
}

}  // namespace maps::ag::detail
