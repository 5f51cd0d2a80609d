// keep_scalar(x, ...): an empty asm that takes each double in a register of its own.
// Eigen runs a fixed 3-vector as a 2-wide SSE packet plus a scalar, and GCC's SLP
// vectoriser packs scalar code for 3 components the same way; either way every dot
// product and every scalar-times-vector then costs a shuffle. A small model's step
// is one serial chain (the elastic pendulum's: norm, sqrt, division, ...), so those
// shuffles lengthen the step. Code that writes a small state component by component
// ends each sub-flow with keep_scalar on the new components: the vectoriser cannot
// pack values an asm needs one by one, and the compiler emits no instruction for it.
#pragma once

namespace raydamp::detail {

inline void keep_scalar_one(double& x) {
#if defined(__GNUC__) && defined(__SSE2__)
  asm("" : "+x"(x));
#else
  (void)x;
#endif
}

template <class... T>
inline void keep_scalar(T&... x) {
  (keep_scalar_one(x), ...);
}

}  // namespace raydamp::detail
