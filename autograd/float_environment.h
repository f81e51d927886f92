#pragma once

// Denormal (subnormal) floats: arithmetic on them takes a slow microcode path on x86, tens of times slower than on
// normal numbers. Training makes them: once MAPS's selector sharpens, the softmax scores of unused modules fall
// below float's smallest normal (1.2e-38), every product with them is denormal, and a training step runs 3-6x
// slower (docs/performance.md, "Denormals"). Flushing them to zero (x86's FTZ and DAZ bits; aarch64's FZ) changes
// only values below 1.2e-38 (float) and 2.2e-308 (double); TensorFlow does it by default and PyTorch offers it
// (torch.set_flush_denormal). The mode is per thread: parallel_for's threads take the calling thread's mode.
namespace maps::ag {

// Whether this build and CPU can flush denormals to zero.
bool flush_denormal_supported();

// Turns flushing on or off for the calling thread (and so for the ops it runs, on any number of threads); returns
// the previous setting. Where unsupported, does nothing and returns false.
bool set_flush_denormal(bool on);

// The calling thread's setting.
bool flush_denormal();

// Sets the mode for its lifetime, then restores the one it found.
class FlushDenormalGuard {
 public:
  explicit FlushDenormalGuard(bool on = true) : previous_(set_flush_denormal(on)) {}
  ~FlushDenormalGuard() { set_flush_denormal(previous_); }
  FlushDenormalGuard(const FlushDenormalGuard&) = delete;
  FlushDenormalGuard& operator=(const FlushDenormalGuard&) = delete;

 private:
  bool previous_;
};

namespace detail {
// The calling thread's raw denormal bits, and setting them (parallel_for hands them to its threads).
unsigned denormal_bits();
void set_denormal_bits(unsigned bits);
}  // namespace detail

}  // namespace maps::ag
