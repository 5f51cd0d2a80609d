// Scratch vectors for the sparse structure kinds. Their flows need a few n-vectors
// beyond the generic Workspace (the Chebyshev recurrence, M^{-1} x inside K M^{-1} x),
// and the model interface passes none to rate() or solve_shifted(). One set per
// thread, sized at first use: the step loop never allocates after its first step,
// and runs on different threads never share a buffer.
#pragma once

#include <Eigen/Core>
#include <array>

namespace raydamp {

enum ScratchSlot { kScratchSolve, kScratchProduct, kScratchT0, kScratchT1, kScratchT2, kScratchSum, kScratchSum2,
                   kScratchSlots };

inline Eigen::VectorXd& thread_scratch(ScratchSlot slot, Eigen::Index n) {
  thread_local std::array<Eigen::VectorXd, kScratchSlots> buffers;
  Eigen::VectorXd& b = buffers[slot];
  if (b.size() != n) b.resize(n);
  return b;
}

}  // namespace raydamp
