// Force-included (-include) into our translation units by CMakeLists.txt when the compiler is
// GCC older than 12.3. GCC 12.2 (Debian 12's) reports "'__Y' is used uninitialized" inside its
// own avx512fintrin.h whenever Eigen's AVX-512 packet code (exp, log, pow, sqrt, casts) is inlined
// into our code: GCC bug 105593, fixed in 12.3. Including the intrinsics once here, with those two
// warnings off for that header only, keeps -Wall -Wextra clean without silencing them in our code.
#pragma once
#if defined(__GNUC__) && !defined(__clang__) && defined(__AVX512F__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wuninitialized"
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#include <immintrin.h>
#pragma GCC diagnostic pop
#endif
