#include "autograd/gemm_bf16.h"

#include <algorithm>
#include <cstring>
#include <stdexcept>
#include <vector>

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#define MAPS_BF16_KERNEL 1
#else
#define MAPS_BF16_KERNEL 0
#endif

namespace maps::ag::detail {
namespace {

using i64 = std::int64_t;

// A float's bfloat16: its upper 16 bits after rounding to nearest even; a NaN keeps its sign and becomes quiet.
std::uint16_t to_bf16_bits(float x) {
  std::uint32_t bits = 0;
  std::memcpy(&bits, &x, sizeof bits);
  if ((bits & 0x7FFFFFFFu) > 0x7F800000u) return static_cast<std::uint16_t>((bits >> 16) | 0x0040u);
  bits += 0x7FFFu + ((bits >> 16) & 1u);
  return static_cast<std::uint16_t>(bits >> 16);
}

}  // namespace

float round_to_bf16(float x) {
  const std::uint32_t bits = static_cast<std::uint32_t>(to_bf16_bits(x)) << 16;
  float rounded = 0.0f;
  std::memcpy(&rounded, &bits, sizeof rounded);
  return rounded;
}

#if MAPS_BF16_KERNEL

std::string avx512_bf16_missing() {
  __builtin_cpu_init();
  std::string missing;
  for (const char* feature : {"avx512f", "avx512bw", "avx512bf16"}) {
    const std::string name = feature;
    // __builtin_cpu_supports takes a string literal only.
    const bool has = name == "avx512f"    ? __builtin_cpu_supports("avx512f")
                     : name == "avx512bw" ? __builtin_cpu_supports("avx512bw")
                                          : __builtin_cpu_supports("avx512bf16");
    if (!has) missing += (missing.empty() ? "" : ", ") + std::string(feature);
  }
  return missing;
}

bool cpu_has_avx512_bf16() {
  static const bool has = avx512_bf16_missing().empty();
  return has;
}

// Named, not anonymous: a unity batch also holds gemm_f32.cpp, whose kernel has the same names.
namespace bf16_kernel {

#define MAPS_BF16_TARGET __attribute__((target("avx512f,avx512bw,avx512bf16")))

constexpr int kLanes = 16;                      // float32 lanes of a register
constexpr int kTileRows = 8, kTileVectors = 2;  // C's tile: 8 rows x 32 columns in 16 accumulators
constexpr int kWidth = kTileVectors * kLanes;
// Inner dimension summed in equal blocks of at most this many (even): a packed strip of A (8 rows, 320 pairs of
// halves: 5 KB) and a packed panel of B (32 columns: 20 KB) stay in L1 while a tile is summed.
constexpr i64 kInnerBlock = 320;
constexpr i64 kRowChunk = 256;

// Pairs of bfloat16, [e0, o0, e1, o1, ...]: 16 floats of an even row (e) and 16 of the next odd row (o), rounded
// to nearest even, one 32-bit word per column.
MAPS_BF16_TARGET __m512i interleaved_pairs(__m512 even, __m512 odd) {
  const __m512i halves = (__m512i)_mm512_cvtne2ps_pbh(odd, even);  // [e0..e15, o0..o15]
  const __m512i order = _mm512_set_epi16(31, 15, 30, 14, 29, 13, 28, 12, 27, 11, 26, 10, 25, 9, 24, 8, 23, 7, 22, 6, 21,
                                         5, 20, 4, 19, 3, 18, 2, 17, 1, 16, 0);
  return _mm512_permutexvar_epi16(order, halves);
}

MAPS_BF16_TARGET __mmask16 first(i64 n) {
  return n >= 16 ? static_cast<__mmask16>(0xFFFF) : static_cast<__mmask16>((1u << std::max<i64>(n, 0)) - 1u);
}

// The words of 16 columns (under `mask`) of two rows of floats, `even` and `even + stride` (zero when !has_odd).
MAPS_BF16_TARGET __m512i pair_words(const float* even, i64 stride, __mmask16 mask, bool has_odd) {
  const __m512 e = _mm512_maskz_loadu_ps(mask, even);
  const __m512 o = has_odd ? _mm512_maskz_loadu_ps(mask, even + stride) : _mm512_setzero_ps();
  return interleaved_pairs(e, o);
}

// Touches the cache lines of `count` floats from `x` ahead of their use. Packing converts as it reads, so a block
// whose source is out of L2 (a step's activations, written long before their weight gradient reads them) stalls on
// each row; the hardware prefetchers start late on short runs far apart. Measured (AMD EPYC Zen 5, one thread,
// operands rotated through 5 MB / 42 MB): [128, 640]^T x [640, 128] 92 -> 64 / 114 -> 87 us (61 in cache),
// [640, 128] x [128, 128]^T 68 -> 58 / 93 -> 72 us; the Gravity bf16 step 5-10% faster. Prefetching in the float32
// kernel's tile (which reads A in place) measured slower, in and out of cache.
inline void prefetch_floats(const float* x, i64 count) {
  for (i64 i = 0; i < count; i += 16) __builtin_prefetch(x + i, 0, 3);
}

constexpr i64 kPrefetchPairs = 8;

// kc floats along k, adjacent in memory, as the words of their (kc + 1) / 2 pairs (the last padded with a zero),
// word p at dst[p * stride]: 32 floats converted at once, their 16 words spread.
MAPS_BF16_TARGET void pack_run(const float* run, i64 kc, std::uint32_t* dst, i64 stride) {
  const i64 pairs = (kc + 1) / 2;
  alignas(64) std::uint32_t words[16];
  for (i64 p = 0; p < pairs; p += 16) {
    const __m512 low = _mm512_maskz_loadu_ps(first(kc - 2 * p), run + 2 * p);
    const __m512 high = _mm512_maskz_loadu_ps(first(kc - 2 * p - 16), run + 2 * p + 16);
    const __m512i converted = (__m512i)_mm512_cvtne2ps_pbh(high, low);
    const i64 count = std::min<i64>(16, pairs - p);
    if (stride == 1) {
      _mm512_mask_storeu_epi32(dst + p, first(count), converted);
      continue;
    }
    _mm512_store_si512(words, converted);
    for (i64 t = 0; t < count; ++t) dst[(p + t) * stride] = words[t];
  }
}

// A packed block of A is in one of two layouts, whichever A's storage makes cheap to write: row-major words (A
// stored row-major: a row's pairs are adjacent floats, converted 32 at a time and stored in order), or strips of
// kTileRows rows, each pair-major (A stored transposed: a pair's two k are two stored rows, whose words for 16 rows
// come out of one interleave). A tile reads word (r, p) at r * row_stride + p * pair_stride from its first row's.
struct PackedA {
  bool rows_of_words;
  i64 pairs;
  i64 word(i64 r, i64 p) const {
    return rows_of_words ? r * pairs + p : (r / kTileRows) * pairs * kTileRows + p * kTileRows + r % kTileRows;
  }
  i64 row_stride() const { return rows_of_words ? pairs : 1; }
  i64 pair_stride() const { return rows_of_words ? 1 : kTileRows; }
};

inline PackedA packed_a_layout(StridedF32 a, i64 kc) { return {a.row_stride != 1 && a.col_stride == 1, (kc + 1) / 2}; }

// A's rows [i0, i0 + rows) and inner block [k0, k0 + kc) as bfloat16 pairs (at layout.word): the word of row r and
// pair p holds A(i0 + r, k0 + 2p) in its low half and A(i0 + r, k0 + 2p + 1) in its high half (zero past the block).
MAPS_BF16_TARGET void pack_a(StridedF32 a, i64 i0, i64 rows, i64 k0, i64 kc, const PackedA& layout,
                             std::uint32_t* out) {
  const i64 pairs = layout.pairs;
  if (layout.rows_of_words) {
    for (i64 r = 0; r < rows; ++r) {
      if (r + 8 < rows) prefetch_floats(a.data + (i0 + r + 8) * a.row_stride + k0, kc);
      pack_run(a.data + (i0 + r) * a.row_stride + k0, kc, out + r * pairs, 1);
    }
    return;
  }
  if (a.row_stride == 1) {  // A stored transposed (X^T G): a pair's two k are two rows of the stored matrix
    for (i64 p = 0; p < pairs; ++p) {
      const float* even = a.data + (k0 + 2 * p) * a.col_stride + i0;
      const bool has_odd = 2 * p + 1 < kc;
      if (2 * (p + kPrefetchPairs) + 1 < kc) {
        prefetch_floats(even + 2 * kPrefetchPairs * a.col_stride, rows);
        prefetch_floats(even + (2 * kPrefetchPairs + 1) * a.col_stride, rows);
      }
      for (i64 r = 0; r < rows; r += 16) {
        const __mmask16 mask = first(rows - r);
        const __m512i words = pair_words(even + r, a.col_stride, mask, has_odd);  // rows r..r+15: two strips' words
        _mm512_mask_storeu_epi32(out + layout.word(r, p), static_cast<__mmask16>(mask & 0xFF), words);
        if (rows - r > 8)  // lanes 8..15 moved down to 0..7 for the next strip
          _mm512_mask_storeu_epi32(out + layout.word(r + 8, p), static_cast<__mmask16>(mask >> 8),
                                   _mm512_maskz_alignr_epi32(0xFF, words, words, 8));
      }
    }
    return;
  }
  for (i64 p = 0; p < pairs; ++p)
    for (i64 r = 0; r < rows; ++r) {
      const float* x = a.data + (i0 + r) * a.row_stride + (k0 + 2 * p) * a.col_stride;
      const std::uint32_t low = to_bf16_bits(x[0]);
      const std::uint32_t high = 2 * p + 1 < kc ? to_bf16_bits(x[a.col_stride]) : 0u;
      out[layout.word(r, p)] = low | (high << 16);
    }
}

// B's inner block [k0, k0 + kc) and columns [j0, j0 + cols) as a panel of `pairs` rows of kWidth words: word j of
// pair p holds B(k0 + 2p, j0 + j) in its low half and B(k0 + 2p + 1, j0 + j) in its high half (zero past the block
// and past the last column), the layout VDPBF16PS multiplies against a broadcast pair of A.
MAPS_BF16_TARGET void pack_b(StridedF32 b, i64 k0, i64 kc, i64 j0, i64 cols, std::uint32_t* panel) {
  const i64 pairs = (kc + 1) / 2;
  if (b.col_stride == 1) {  // B row-major: two rows of it make a row of words
    for (i64 p = 0; p < pairs; ++p) {
      const float* even = b.data + (k0 + 2 * p) * b.row_stride + j0;
      const bool has_odd = 2 * p + 1 < kc;
      if (2 * (p + kPrefetchPairs) + 1 < kc) {
        prefetch_floats(even + 2 * kPrefetchPairs * b.row_stride, cols);
        prefetch_floats(even + (2 * kPrefetchPairs + 1) * b.row_stride, cols);
      }
      for (int v = 0; v < kWidth; v += 16) {
        const __mmask16 mask = first(cols - v);
        _mm512_storeu_si512(panel + p * kWidth + v, pair_words(even + v, b.row_stride, mask, has_odd));
      }
    }
    return;
  }
  std::fill(panel, panel + pairs * kWidth, 0u);
  if (b.row_stride == 1) {  // B stored transposed (W^T): a column's k are adjacent; 32 floats make 16 pairs' words
    for (i64 j = 0; j < cols; ++j) {
      if (j + 8 < cols) prefetch_floats(b.data + (j0 + j + 8) * b.col_stride + k0, kc);
      pack_run(b.data + (j0 + j) * b.col_stride + k0, kc, panel + j, kWidth);
    }
    return;
  }
  for (i64 p = 0; p < pairs; ++p)
    for (i64 j = 0; j < cols; ++j) {
      const float* x = b.data + (k0 + 2 * p) * b.row_stride + (j0 + j) * b.col_stride;
      const std::uint32_t low = to_bf16_bits(x[0]);
      const std::uint32_t high = 2 * p + 1 < kc ? to_bf16_bits(x[b.row_stride]) : 0u;
      panel[p * kWidth + j] = low | (high << 16);
    }
}

// C tile [MR, cols] (=|+=) MR packed rows of A (word (r, p) at a[r * row_stride + p * pair_stride]) times the
// packed panel.
template <int MR>
MAPS_BF16_TARGET void tile(const std::uint32_t* a, i64 row_stride, i64 pair_stride, const std::uint32_t* panel,
                           i64 pairs, float* c, i64 ldc, bool add, int cols) {
  __m512 acc[MR][kTileVectors];
  for (int r = 0; r < MR; ++r)
    for (int v = 0; v < kTileVectors; ++v) acc[r][v] = _mm512_setzero_ps();
  for (i64 p = 0; p < pairs; ++p) {
    __m512bh b[kTileVectors];
    for (int v = 0; v < kTileVectors; ++v) b[v] = (__m512bh)(_mm512_loadu_si512(panel + p * kWidth + v * kLanes));
    for (int r = 0; r < MR; ++r) {
      const __m512bh x = (__m512bh)(_mm512_set1_epi32(static_cast<int>(a[p * pair_stride + r * row_stride])));
      for (int v = 0; v < kTileVectors; ++v) acc[r][v] = _mm512_dpbf16_ps(acc[r][v], x, b[v]);
    }
  }
  for (int r = 0; r < MR; ++r) {
    float* row = c + r * ldc;
    for (int v = 0; v < kTileVectors && v * kLanes < cols; ++v) {
      const int left = std::min(kLanes, cols - v * kLanes);
      const __mmask16 mask =
          left >= kLanes ? static_cast<__mmask16>(0xFFFF) : static_cast<__mmask16>((1u << left) - 1u);
      __m512 sum = acc[r][v];
      if (add) sum = _mm512_add_ps(sum, _mm512_maskz_loadu_ps(mask, row + v * kLanes));
      _mm512_mask_storeu_ps(row + v * kLanes, mask, sum);
    }
  }
}

template <int MR>
MAPS_BF16_TARGET void tail_tile(int rows, const std::uint32_t* a, i64 row_stride, i64 pair_stride,
                                const std::uint32_t* panel, i64 pairs, float* c, i64 ldc, bool add, int cols) {
  if constexpr (MR > 0) {
    if (rows == MR) {
      tile<MR>(a, row_stride, pair_stride, panel, pairs, c, ldc, add, cols);
    } else {
      tail_tile<MR - 1>(rows, a, row_stride, pair_stride, panel, pairs, c, ldc, add, cols);
    }
  }
}

MAPS_BF16_TARGET void blocked_product(StridedF32 a, StridedF32 b, float* c, i64 ldc, i64 m, i64 n, i64 k,
                                      bool accumulate) {
  thread_local std::vector<std::uint32_t> packed_a, packed_b;
  // Equal blocks, each of an even length but perhaps the last, so each element's sum is split alike everywhere.
  const i64 blocks = (k + kInnerBlock - 1) / kInnerBlock;
  const i64 block = ((k + blocks - 1) / blocks + 1) / 2 * 2;
  const i64 panels = (n + kWidth - 1) / kWidth;
  for (i64 k0 = 0; k0 < k; k0 += block) {
    const i64 kc = std::min(block, k - k0), pairs = (kc + 1) / 2;
    const bool add = accumulate || k0 > 0;
    // Every panel of B's block once (a panel is 20 KB: it stays in L1 while a chunk of A's rows goes by), then A's
    // rows a chunk at a time (256 rows: 160 KB, in L2), each packed once.
    packed_b.resize(static_cast<std::size_t>(panels * pairs * kWidth));
    for (i64 p = 0; p < panels; ++p)
      pack_b(b, k0, kc, p * kWidth, std::min<i64>(kWidth, n - p * kWidth), packed_b.data() + p * pairs * kWidth);
    for (i64 i0 = 0; i0 < m; i0 += kRowChunk) {
      const i64 mc = std::min(kRowChunk, m - i0);
      const PackedA layout = packed_a_layout(a, kc);
      packed_a.resize(static_cast<std::size_t>((mc + kTileRows - 1) / kTileRows * kTileRows * pairs));
      pack_a(a, i0, mc, k0, kc, layout, packed_a.data());
      for (i64 p = 0; p < panels; ++p) {
        const int cols = static_cast<int>(std::min<i64>(kWidth, n - p * kWidth));
        const std::uint32_t* panel = packed_b.data() + p * pairs * kWidth;
        float* c_panel = c + p * kWidth;
        i64 r = 0;
        for (; r + kTileRows <= mc; r += kTileRows)
          tile<kTileRows>(packed_a.data() + layout.word(r, 0), layout.row_stride(), layout.pair_stride(), panel, pairs,
                          c_panel + (i0 + r) * ldc, ldc, add, cols);
        if (r < mc)
          tail_tile<kTileRows - 1>(static_cast<int>(mc - r), packed_a.data() + layout.word(r, 0), layout.row_stride(),
                                   layout.pair_stride(), panel, pairs, c_panel + (i0 + r) * ldc, ldc, add, cols);
      }
    }
  }
}

}  // namespace bf16_kernel

void gemm_bf16(StridedF32 a, StridedF32 b, float* c, i64 ldc, i64 m, i64 n, i64 k, bool accumulate) {
  if (!cpu_has_avx512_bf16())
    throw std::logic_error("the bfloat16 matrix product needs AVX512-BF16, and this CPU lacks " +
                           avx512_bf16_missing() + " (train.precision \"float32\" runs on any CPU)");
  if (m <= 0 || n <= 0) return;
  if (k <= 0) {
    if (!accumulate)
      for (i64 i = 0; i < m; ++i) std::fill(c + i * ldc, c + i * ldc + n, 0.0f);
    return;
  }
  bf16_kernel::blocked_product(a, b, c, ldc, m, n, k, accumulate);
}

#else

std::string avx512_bf16_missing() { return "an x86-64 CPU with AVX512-BF16 (this build is for another)"; }
bool cpu_has_avx512_bf16() { return false; }
void gemm_bf16(StridedF32, StridedF32, float*, std::int64_t, std::int64_t, std::int64_t, std::int64_t, bool) {
  throw std::logic_error("the bfloat16 matrix product needs an x86-64 CPU with AVX512-BF16");
}

#endif

}  // namespace maps::ag::detail
