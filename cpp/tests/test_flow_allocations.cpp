// The damping flows that run inside the step loop allocate nothing: Eigen's own check (EIGEN_RUNTIME_NO_MALLOC,
// its assertion made to throw, so it works in a release build) around each call, for the Kepler kinds' drag in
// every direction (fixed axes too) and for isotropic damping. Compiled alone: the macros must come before any Eigen header.
// (The radial and tangential drag first normalised a run-time-size segment, a heap VectorXd per planet per flow.)
#include <stdexcept>
#define eigen_assert(x) \
  do {                  \
    if (!(x)) throw std::runtime_error(#x); \
  } while (0)
#define EIGEN_RUNTIME_NO_MALLOC

#include <cstdio>
#include <functional>

#include "check.hpp"
#include "raydamp/damping/isotropic_damping.hpp"
#include "raydamp/models/planets.hpp"

using namespace raydamp;

namespace {

bool allocates(const std::function<void()>& flow) {
  Eigen::internal::set_is_malloc_allowed(false);
  bool allocated = false;
  try {
    flow();
  } catch (const std::runtime_error&) {
    allocated = true;
  }
  Eigen::internal::set_is_malloc_allowed(true);
  return allocated;
}

}  // namespace

int main() {
  struct Mass {
    Eigen::VectorXd m = Eigen::VectorXd::Constant(6, 1.3);
  } mass;
  Eigen::VectorXd q(6), p(6), g(6), out(6), xi(6);
  q << 0.3, -1.1, 0.7, 1.0, 2.0, 3.0;
  p.setConstant(0.5);
  g.setConstant(0.1);
  xi.setConstant(0.3);
  // The check itself: a flow that makes a VectorXd is caught.
  CHECK(allocates([&] { Eigen::VectorXd made = q.segment(0, 3).normalized(); (void)made; }));
  Eigen::MatrixXd A(3, 3);
  A << 2.0, 0.3, -0.4, 0.3, 1.0, 0.2, -0.4, 0.2, 0.5;
  for (DragDirection direction :
       {DragDirection::isotropic, DragDirection::radial, DragDirection::tangential, DragDirection::axes}) {
    PlanetDrag drag;
    drag.set({0.2, 0.1}, 3, direction, A);
    const PlanetDrag::Factors f = drag.factors(0.1);
    CHECK(!allocates([&] { drag.decay(q, f, p); }));
    CHECK(!allocates([&] { drag.decay_affine(q, f, g, p); }));
    CHECK(!allocates([&] { drag.rate(q, p, out); }));
    CHECK(!allocates([&] { drag.solve_shifted(q, 0.3, p); }));
    CHECK(!allocates([&] { drag.add_noise(q, f, mass, 0.7, xi, p); }));
  }
  IsotropicDamping isotropic;
  isotropic.a = 0.4;
  const DecayFactors f = isotropic.factors(0.1);
  CHECK(!allocates([&] { isotropic.decay(q, f, p); }));
  CHECK(!allocates([&] { isotropic.decay_affine(q, f, g, p); }));
  if (test::failures == 0) std::printf("no damping flow allocates\n");
  return test::failures == 0 ? 0 : 1;
}
