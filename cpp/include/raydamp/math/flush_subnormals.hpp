// Subnormal doubles (below 2.2e-308) are flushed to zero while a run steps.
//
// A damped run that outlives its decay reaches them: the damping flow multiplies p by
// e^{-eps h} < 1, and on the smallest subnormals that product rounds back to the same
// value, so the state never reaches zero. It cycles among subnormals for the rest of
// the run, and x86 processors take a microcode assist on every operation that reads or
// makes one: the damped pendulum's 3s step went from 5 to 130 ns, for values that
// no result can show. Flush-to-zero and denormals-are-zero (the MXCSR's FTZ and DAZ
// bits) make those values 0 instead. Only values below the smallest normal double
// change; every other operation rounds as before.
//
// MXCSR is per thread: the guard sets it for the calling thread (each ensemble worker
// runs its own run_steps) and restores the caller's on exit, so nothing outside the run
// (NumPy, the interpreter) sees the change.
#pragma once

#if defined(__SSE2__)
#include <xmmintrin.h>
#endif

namespace raydamp {

class FlushSubnormals {
 public:
#if defined(__SSE2__)
  static constexpr unsigned kBits = 0x8040u;  // FTZ (bit 15) and DAZ (bit 6)
  FlushSubnormals() : saved_(_mm_getcsr()) { _mm_setcsr(saved_ | kBits); }
  ~FlushSubnormals() { _mm_setcsr(saved_); }

 private:
  unsigned saved_;
#else
  FlushSubnormals() = default;  // elsewhere subnormals keep their IEEE meaning (and cost)
#endif

 public:
  FlushSubnormals(const FlushSubnormals&) = delete;
  FlushSubnormals& operator=(const FlushSubnormals&) = delete;
};

}  // namespace raydamp
