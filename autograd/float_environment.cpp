#include "autograd/float_environment.h"

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#endif

namespace maps::ag {
namespace {

#if defined(__x86_64__) || defined(__i386__)
constexpr unsigned kFlushBits = 0x8040u;  // MXCSR: flush-to-zero (bit 15) and denormals-are-zero (bit 6)
unsigned read_bits() { return _mm_getcsr(); }
void write_bits(unsigned bits) { _mm_setcsr(bits); }
#elif defined(__aarch64__)
constexpr unsigned kFlushBits = 1u << 24;  // FPCR.FZ
unsigned read_bits() {
  unsigned long fpcr = 0;
  asm volatile("mrs %0, fpcr" : "=r"(fpcr));
  return static_cast<unsigned>(fpcr);
}
void write_bits(unsigned bits) {
  const unsigned long fpcr = bits;
  asm volatile("msr fpcr, %0" : : "r"(fpcr));
}
#else
constexpr unsigned kFlushBits = 0u;
unsigned read_bits() { return 0u; }
void write_bits(unsigned) {}
#endif

}  // namespace

bool flush_denormal_supported() { return kFlushBits != 0u; }

bool flush_denormal() { return kFlushBits != 0u && (read_bits() & kFlushBits) == kFlushBits; }

bool set_flush_denormal(bool on) {
  const bool previous = flush_denormal();
  detail::set_denormal_bits(on ? kFlushBits : 0u);
  return previous;
}

namespace detail {

unsigned denormal_bits() { return read_bits() & kFlushBits; }

void set_denormal_bits(unsigned bits) {
  if (kFlushBits == 0u) return;
  const unsigned current = read_bits();
  if ((current & kFlushBits) != bits) write_bits((current & ~kFlushBits) | (bits & kFlushBits));
}

}  // namespace detail
}  // namespace maps::ag
