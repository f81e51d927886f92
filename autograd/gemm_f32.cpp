#include "autograd/gemm_f32.h"

#include <stdexcept>

#if MAPS_F32_KERNEL
#include <immintrin.h>

#include <algorithm>
#include <vector>
#endif

namespace maps::ag::detail {

#if MAPS_F32_KERNEL
namespace {

using i64 = std::int64_t;

// The vector instructions the kernel is written in, and its tile shapes for them: C's tile (rows x vectors) must
// fit the registers with the vectors of B and a broadcast of A beside it.
#if defined(__AVX512F__)
struct Isa {
  static constexpr int kLanes = 16;                      // floats per register; 32 registers
  static constexpr int kTileRows = 8, kTileVectors = 2;  // 16 accumulators
  static constexpr int kNarrowRows = 12;                 // outputs of one register's width: 12 accumulators
  static constexpr int kTransposedRows = 12, kTransposedVectors = 2;  // C^T of a narrow output: 24 accumulators
  using V = __m512;
  static V zero() { return _mm512_setzero_ps(); }
  static V load(const float* p) { return _mm512_loadu_ps(p); }
  static V broadcast(float x) { return _mm512_set1_ps(x); }
  static V fma(V a, V b, V c) { return _mm512_fmadd_ps(a, b, c); }
  static V add(V a, V b) { return _mm512_add_ps(a, b); }
  static void store(float* p, V v) { _mm512_storeu_ps(p, v); }
  // The first n (0..16) floats at p, zero past them; lanes past n are neither read nor written.
  static __mmask16 mask(int n) {
    if (n <= 0) return 0;
    return n >= kLanes ? static_cast<__mmask16>(0xFFFF) : static_cast<__mmask16>((1u << n) - 1u);
  }
  static V load_first(const float* p, int n) { return _mm512_maskz_loadu_ps(mask(n), p); }
  static void store_first(float* p, V v, int n) { _mm512_mask_storeu_ps(p, mask(n), v); }
};
#else
struct Isa {
  static constexpr int kLanes = 8;                                   // floats per register; 16 registers
  static constexpr int kTileRows = 6, kTileVectors = 2;              // 12 accumulators
  static constexpr int kNarrowRows = 8;                              // 8 accumulators
  static constexpr int kTransposedRows = 6, kTransposedVectors = 2;  // 12 accumulators
  using V = __m256;
  static V zero() { return _mm256_setzero_ps(); }
  static V load(const float* p) { return _mm256_loadu_ps(p); }
  static V broadcast(float x) { return _mm256_set1_ps(x); }
  static V fma(V a, V b, V c) { return _mm256_fmadd_ps(a, b, c); }
  static V add(V a, V b) { return _mm256_add_ps(a, b); }
  static void store(float* p, V v) { _mm256_storeu_ps(p, v); }
  static __m256i mask(int n) {
    const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    return _mm256_cmpgt_epi32(_mm256_set1_epi32(n), lane);  // lane i on when i < n
  }
  static V load_first(const float* p, int n) { return _mm256_maskload_ps(p, mask(n)); }
  static void store_first(float* p, V v, int n) { _mm256_maskstore_ps(p, mask(n), v); }
};
#endif
constexpr int kLanes = Isa::kLanes;

// Inner dimension summed in equal blocks of at most this many: a strip of A's rows (10 KB for 8 rows) and a
// packed panel of B (40 KB for 32 columns) stay in L1 while a tile is summed.
constexpr i64 kInnerBlock = 320;
// Rows of A per pass over the packed panels (a [256, 320] strip is 320 KB: it stays in L2 while every panel of B
// goes by), and columns of B packed at once.
constexpr i64 kRowChunk = 256;
constexpr i64 kColumnChunk = 256;
// A row-major B whose rows are fewer floats apart than this is read in place.
constexpr i64 kInPlaceRowStride = 256;

// C tile [MR, cols] (=|+=) sum over k < kc of A(r, k) * panel[k, :], the panel's rows `panel_ld` apart and readable
// to the full tile width, and A(r, k) at a[r * a_rs + k * a_cs]. (Masked reads of the panel, tried for narrow
// panels read in place, halved the kernel's speed: narrow panels are packed instead.)
template <int MR, int NV>
void tile(const float* a, i64 a_rs, i64 a_cs, const float* panel, i64 panel_ld, i64 kc, float* c, i64 ldc, bool add,
          int cols) {
  Isa::V acc[MR][NV];
  for (int r = 0; r < MR; ++r)
    for (int v = 0; v < NV; ++v) acc[r][v] = Isa::zero();
  for (i64 k = 0; k < kc; ++k) {
    Isa::V b[NV];
    for (int v = 0; v < NV; ++v) b[v] = Isa::load(panel + k * panel_ld + v * kLanes);
    const float* ak = a + k * a_cs;
    for (int r = 0; r < MR; ++r) {
      const Isa::V x = Isa::broadcast(ak[r * a_rs]);
      for (int v = 0; v < NV; ++v) acc[r][v] = Isa::fma(x, b[v], acc[r][v]);
    }
  }
  for (int r = 0; r < MR; ++r) {
    float* row = c + r * ldc;
    for (int v = 0; v < NV && v * kLanes < cols; ++v) {
      const int left = cols - v * kLanes;
      Isa::V sum = acc[r][v];
      if (add) sum = Isa::add(sum, Isa::load_first(row + v * kLanes, left));
      Isa::store_first(row + v * kLanes, sum, left);
    }
  }
}

// tile<R, NV> for the last rows - fewer than MR - of a strip.
template <int MR, int NV>
void tail_tile(int rows, const float* a, i64 a_rs, i64 a_cs, const float* panel, i64 panel_ld, i64 kc, float* c,
               i64 ldc, bool add, int cols) {
  if constexpr (MR > 0) {
    if (rows == MR) {
      tile<MR, NV>(a, a_rs, a_cs, panel, panel_ld, kc, c, ldc, add, cols);
    } else {
      tail_tile<MR - 1, NV>(rows, a, a_rs, a_cs, panel, panel_ld, kc, c, ldc, add, cols);
    }
  }
}

// Packs B's rows [k0, k0 + kc) and columns [j0, j0 + cols) as a panel [kc][width], zero past the last column.
void pack_panel(StridedF32 b, i64 k0, i64 kc, i64 j0, i64 cols, int width, float* panel) {
  if (b.col_stride == 1) {
    for (i64 k = 0; k < kc; ++k) {
      const float* src = b.data + (k0 + k) * b.row_stride + j0;
      for (int v = 0; v < width; v += kLanes)
        Isa::store(panel + k * width + v, Isa::load_first(src + v, static_cast<int>(cols) - v));
    }
    return;
  }
  // A transposed B: each of its columns is contiguous along k in memory, read as such.
  for (i64 j = 0; j < cols; ++j) {
    const float* src = b.data + (j0 + j) * b.col_stride + k0 * b.row_stride;
    for (i64 k = 0; k < kc; ++k) panel[k * width + j] = src[k * b.row_stride];
  }
  for (i64 k = 0; k < kc; ++k) std::fill(panel + k * width + cols, panel + (k + 1) * width, 0.0f);
}

template <int MR, int NV>
void blocked_product(StridedF32 a, StridedF32 b, float* c, i64 ldc, i64 m, i64 n, i64 k, bool accumulate) {
  constexpr int width = NV * kLanes;
  thread_local std::vector<float> packed;
  const i64 blocks = (k + kInnerBlock - 1) / kInnerBlock, block = (k + blocks - 1) / blocks;
  for (i64 k0 = 0; k0 < k; k0 += block) {
    const i64 kc = std::min(block, k - k0);
    const bool add = accumulate || k0 > 0;
    for (i64 j0 = 0; j0 < n; j0 += kColumnChunk) {
      const i64 nc = std::min(kColumnChunk, n - j0), panels = (nc + width - 1) / width;
      // A full-width panel of a row-major B with short rows is read in place (2% faster a step than packing it:
      // its cold rows are fetched while the tile computes). Rows of 1 KB or more apart would meet in the same few
      // L1 sets (1024^3: 14-15 ms in place, 11-13.6 packed): packed, as are the columns of a transposed B
      // (gathered once) and a narrower panel (padded with zeros so the tile reads full registers).
      const bool short_rows = b.col_stride == 1 && b.row_stride < kInPlaceRowStride;
      packed.resize(static_cast<std::size_t>(panels * kc * width));
      for (i64 p = 0; p < panels; ++p) {
        const i64 cols = std::min<i64>(width, nc - p * width);
        if (!short_rows || cols < width)
          pack_panel(b, k0, kc, j0 + p * width, cols, width, packed.data() + p * kc * width);
      }
      for (i64 i0 = 0; i0 < m; i0 += kRowChunk) {
        const i64 mc = std::min(kRowChunk, m - i0);
        for (i64 p = 0; p < panels; ++p) {
          const int cols = static_cast<int>(std::min<i64>(width, nc - p * width));
          const bool in_place = short_rows && cols == width;
          const float* panel = in_place ? b.data + k0 * b.row_stride + j0 + p * width : packed.data() + p * kc * width;
          const i64 panel_ld = in_place ? b.row_stride : width;
          float* c_panel = c + j0 + p * width;
          i64 i = i0;
          for (; i + MR <= i0 + mc; i += MR)
            tile<MR, NV>(a.data + i * a.row_stride + k0 * a.col_stride, a.row_stride, a.col_stride, panel, panel_ld, kc,
                         c_panel + i * ldc, ldc, add, cols);
          if (i < i0 + mc)
            tail_tile<MR - 1, NV>(static_cast<int>(i0 + mc - i), a.data + i * a.row_stride + k0 * a.col_stride,
                                  a.row_stride, a.col_stride, panel, panel_ld, kc, c_panel + i * ldc, ldc, add, cols);
        }
      }
    }
  }
}

}  // namespace

void gemm_f32(StridedF32 a, StridedF32 b, float* c, i64 ldc, i64 m, i64 n, i64 k, bool accumulate) {
  if (m <= 0 || n <= 0) return;
  if (k <= 0) {
    if (!accumulate)
      for (i64 i = 0; i < m; ++i) std::fill(c + i * ldc, c + i * ldc + n, 0.0f);
    return;
  }
  if (n > kLanes) {
    blocked_product<Isa::kTileRows, Isa::kTileVectors>(a, b, c, ldc, m, n, k, accumulate);
    return;
  }
  // A narrow output (a policy's actions, the selector's scores). When A is stored transposed (a weight gradient,
  // X^T G), C^T = B^T A^T runs full-width vectors along C's columns over a cheaply packed A; C is written from it.
  // Measured on [128, 320]^T x [320, 4] and [128, 3520]^T x [3520, 10]: 75-125 GFLOP/s this way, 25-70 directly.
  // The choice depends on the operands' layout only, not on m, so gemm_parallel's row split keeps each element's
  // path.
  if (a.row_stride == 1) {
    // C^T starts from C when accumulating, so each element is summed as ((C + block 1) + block 2) ..., as on the
    // other paths (gemm_parallel's column split can send parts of one product down different paths).
    thread_local std::vector<float> transposed;
    transposed.resize(static_cast<std::size_t>(n * m));
    if (accumulate)
      for (i64 i = 0; i < m; ++i)
        for (i64 j = 0; j < n; ++j) transposed[static_cast<std::size_t>(j * m + i)] = c[i * ldc + j];
    blocked_product<Isa::kTransposedRows, Isa::kTransposedVectors>({b.data, b.col_stride, b.row_stride},
                                                                   {a.data, a.col_stride, a.row_stride},
                                                                   transposed.data(), m, n, m, k, accumulate);
    for (i64 i = 0; i < m; ++i)
      for (i64 j = 0; j < n; ++j) c[i * ldc + j] = transposed[static_cast<std::size_t>(j * m + i)];
    return;
  }
  blocked_product<Isa::kNarrowRows, 1>(a, b, c, ldc, m, n, k, accumulate);
}

#else

void gemm_f32(StridedF32, StridedF32, float*, std::int64_t, std::int64_t, std::int64_t, std::int64_t, bool) {
  throw std::logic_error("gemm_f32: this build has no AVX-512 or AVX2 kernel (kHaveF32Kernel is false)");
}

#endif

}  // namespace maps::ag::detail
