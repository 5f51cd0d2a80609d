// Phase-space state z = (q, p) at time t.
#pragma once

#include <Eigen/Core>

namespace raydamp {

// Dim is the configuration dimension n, fixed at compile time for small models
// (so the step loop works on registers) or Eigen::Dynamic for large ones.
template <int Dim>
using Vector = Eigen::Matrix<double, Dim, 1>;

template <int Dim>
struct State {
  Vector<Dim> q;
  Vector<Dim> p;

  bool all_finite() const { return q.allFinite() && p.allFinite(); }
};

}  // namespace raydamp
