// What the processor offers beyond the build's baseline, asked once (kernels compiled for it with a
// target attribute are chosen at their first call: materials/bouc_wen_lanes.hpp, events/block_sums.hpp).
#pragma once

namespace raydamp {

#if defined(__x86_64__) || defined(__i386__)
inline bool has_avx2() {
  static const bool avx2 = [] {
    __builtin_cpu_init();
    return __builtin_cpu_supports("avx2") != 0;
  }();
  return avx2;
}
#endif

}  // namespace raydamp
