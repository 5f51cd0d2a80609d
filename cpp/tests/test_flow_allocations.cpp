// The damping flows that run inside the step loop allocate nothing: Eigen's own check (EIGEN_RUNTIME_NO_MALLOC,
// its assertion made to throw, so it works in a release build) around each call, for the Kepler kinds' drag in
// every direction (fixed axes too) and for isotropic damping, and a Structure's gradient with its springs. Compiled alone: the macros must come before any Eigen header.
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
#include "raydamp/models/structure.hpp"

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
  // A Structure's kick: K q - f plus the springs' forces, K dense (a few coordinates) or sparse (past
  // kMaxDenseDim), zero or not, and gradient_with_forces. (K q - f in one sparse expression made a heap temporary.)
  for (const int n : {3, 40}) {
    for (const bool frame : {false, true}) {
      SparseColMajor k(n, n);
      if (frame) {
        std::vector<Eigen::Triplet<double>> entries;
        for (int i = 0; i < n; ++i) entries.emplace_back(i, i, -0.1);  // a P-Delta-like softening
        k.setFromTriplets(entries.begin(), entries.end());
      }
      materials::Springs springs;
      for (int s = 0; s < n; ++s) {
        if (s % 2) springs.bouc_wen.add(s - 1, s, materials::BoucWen(10.0, 1.0, 0.1, 0.5, 0.5));
        else springs.bilinear.add(s - 1, s, materials::Bilinear(10.0, 1.0, 0.05));
      }
      const Structure<LumpedMass> structure(LumpedMass(Eigen::VectorXd::Ones(n), "M"), k, springs,
                                            Eigen::VectorXd::Constant(n, 0.2), 0.1, 0.01);
      const Eigen::VectorXd at = Eigen::VectorXd::LinSpaced(n, 0.0, 0.3);
      Eigen::VectorXd grad(n);
      const std::vector<double> sigma(n, 0.5);
      CHECK(!allocates([&] { structure.gradient(at, grad); }));
      CHECK(!allocates([&] { structure.gradient_with_forces(at, sigma.data(), grad); }));
    }
  }
  if (test::failures == 0) std::printf("no damping flow or structure's gradient allocates\n");
  return test::failures == 0 ? 0 : 1;
}
