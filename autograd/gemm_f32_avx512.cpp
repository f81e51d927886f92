// The float32 kernel for AVX-512, compiled with that instruction set's flags (autograd/CMakeLists.txt; without
// them, in a build for another architecture, this file is empty).
#if MAPS_BUILD_F32_AVX512
#define MAPS_F32_VARIANT_AVX512 1
#define MAPS_F32_VARIANT_FUNCTION gemm_f32_avx512
#include "autograd/gemm_f32_kernel.inc"
#endif
