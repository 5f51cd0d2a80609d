// A structure with hysteretic springs: the linear structure of K0 = K + sum_s k_s r_s r_s^T (each
// spring's initial stiffness added to K) with Rayleigh damping C = alpha M + beta K0, plus for each spring
// the difference between its force and its initial stiffness's, r_s (sigma_s(d_s) - k_s d_s):
//   grad V(q) = K0 q - f + sum_s r_s (sigma_s(d_s) - k_s d_s) = K q - f + sum_s r_s sigma_s(d_s),
// the kick taking the last form: K0's product would be work the springs' terms then take back (a frame of
// springs alone has K = 0: its kick has no product at all).
// The damping of the initial stiffness keeps every damping sub-flow exact (and LinearStructure's dense
// modal or sparse Chebyshev flows serve unchanged); its cost is a spurious damping force beta k_s r_s d_s'
// in a spring that has yielded, which a tangent-stiffness damping would drop.
//
// damping_stiffness = "tangent" damps with alpha M + beta K_t instead, K_t the springs' tangent on their
// branches, each branch's flows exact (models/structure_damping.hpp).
//
// The springs are read in the kick at the kick's q, each return map exact for the increment from the
// committed state; the step loop commits once per full step (materials/commit.hpp). A run steps its own
// copy with fresh material states (fresh_run), so one model serves concurrent runs.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "raydamp/materials/springs.hpp"
#include "raydamp/models/linear_structure.hpp"
#include "raydamp/models/structure_damping.hpp"

namespace raydamp {

namespace detail {

// K0 = K + sum_s k_s r_s r_s^T, the springs checked first (their dofs name the spring).
inline SparseColMajor initial_stiffness(const SparseColMajor& k, const materials::Springs& springs, int n) {
  springs.check(n);
  std::vector<Eigen::Triplet<double>> entries;
  springs.for_each([&](const auto& set) {
    for (std::size_t s = 0; s < set.size(); ++s) {
      const double ks = set.material[s].stiffness();
      const int i = set.i[s], j = set.j[s];
      entries.emplace_back(j, j, ks);
      if (i >= 0) {
        entries.emplace_back(i, i, ks);
        entries.emplace_back(i, j, -ks);
        entries.emplace_back(j, i, -ks);
      }
    }
  });
  SparseColMajor added(k.rows(), k.cols());
  added.setFromTriplets(entries.begin(), entries.end());
  SparseColMajor out = k + added;
  out.makeCompressed();
  return out;
}

// A step an implicit method could not solve (implicit/newmark.hpp): its index (-1: none) and why.
struct ImplicitFailure {
  long step = -1;
  std::string message;
};

}  // namespace detail

template <class Mass>
struct Structure : LinearStructure<Mass> {
  using Base = LinearStructure<Mass>;
  using Vec = typename Base::Vec;
  static constexpr const char* name = "structure";
  // Springs make the system nonlinear: the implicit methods, which solve M q'' + C q' + K q = f as one linear
  // system (catalogue.hpp's with_method_for), are refused, naming the method.
  static constexpr bool linear_system = false;

  materials::Springs springs;
  // Hides LinearStructure's damping from the step loop: the same initial damping, or the tangent one, which
  // reads the springs' branches (attached again on every copy, so each run's copy reads its own springs).
  StructureDamping<Mass> damping;
  // What newmark's step reports of a step whose iteration failed: the run's copy's own, as its materials are.
  mutable detail::ImplicitFailure implicit_failure;

  Structure(Mass mass_, const SparseColMajor& k, materials::Springs springs_, const Eigen::VectorXd& f, double alpha,
            double beta, int dense_limit = kMaxDenseDim, bool tangent_damping = false)
      : Base(std::move(mass_), detail::initial_stiffness(k, springs_, static_cast<int>(k.rows())), f, alpha, beta,
             dense_limit),
        springs(std::move(springs_)),
        damping(Base::damping) {
    damping.attach(&springs);
    keep_frame_stiffness(k);
    if (tangent_damping) {
      const Eigen::MatrixXd k0 = Base::dense_stiffness ? *Base::dense_stiffness
                                                       : Eigen::MatrixXd(SparseColMajor(*Base::stiffness));
      damping.use_tangent(Eigen::MatrixXd(Base::mass.matrix()), k0);
    }
  }
  Structure(const Structure& o)
      : Base(o),
        springs(o.springs),
        damping(o.damping),
        frame_stiffness(o.frame_stiffness),
        dense_frame_stiffness(o.dense_frame_stiffness) {
    damping.attach(&springs);
  }
  Structure(Structure&& o) noexcept
      : Base(std::move(o)),
        springs(std::move(o.springs)),
        damping(std::move(o.damping)),
        frame_stiffness(std::move(o.frame_stiffness)),
        dense_frame_stiffness(std::move(o.dense_frame_stiffness)) {
    damping.attach(&springs);
  }
  Structure& operator=(const Structure& o) {
    Base::operator=(o);
    springs = o.springs;
    damping = o.damping;
    frame_stiffness = o.frame_stiffness;
    dense_frame_stiffness = o.dense_frame_stiffness;
    damping.attach(&springs);
    return *this;
  }
  Structure& operator=(Structure&& o) noexcept {
    Base::operator=(std::move(o));
    springs = std::move(o.springs);
    damping = std::move(o.damping);
    frame_stiffness = std::move(o.frame_stiffness);
    dense_frame_stiffness = std::move(o.dense_frame_stiffness);
    damping.attach(&springs);
    return *this;
  }

  // A copy of this structure with every material in its virgin state: what a run steps.
  Structure fresh_run() const {
    Structure out = *this;
    out.springs.reset();
    out.implicit_failure = {};
    return out;
  }

  double potential(const Vec& q) const { return Base::potential(q) + springs_energy(q); }

  void gradient(const Vec& q, Vec& g) const {
    frame_gradient(q, g);
    springs.for_each([&](const auto& set) { set.add_forces(q, g); });
  }

  void hessian_product(const Vec& q, const Vec& v, Vec& out) const {
    Base::hessian_product(q, v, out);
    springs.for_each([&](const auto& set) { set.add_tangent_correction(q, v, out); });
  }

  // grad V(q) with each spring's force sigma_s given (in Springs' order: a saved row's, record/recorder.hpp)
  // instead of read from its material's committed state: the gradient of a row after the run, whose
  // material states are gone.
  void gradient_with_forces(const Vec& q, const double* sigma, Vec& g) const {
    frame_gradient(q, g);
    springs.for_each([&](const auto& set) {
      for (std::size_t s = 0; s < set.size(); ++s) set.scatter(s, sigma[s], g);
      sigma += set.size();
    });
  }

  // Each spring's elastic range [lower, upper] of its deformation from the committed state, in Springs'
  // order (infinite for Bouc-Wen): where a kink locator looks for the next yield.
  void elastic_ranges(double* lower, double* upper) const {
    springs.for_each([&](const auto& set) {
      set.elastic_ranges(lower, upper);
      lower += set.size();
      upper += set.size();
    });
  }

  // The springs' forces sigma_s(d_s) at q from the committed states, in Springs' order.
  std::vector<double> spring_forces(const Vec& q) const {
    std::vector<double> out(springs.size());
    double* at = out.data();
    springs.for_each([&](const auto& set) {
      set.forces(q, at);
      at += set.size();
    });
    return out;
  }

 private:
  // K as given, without the springs' initial stiffness: null where it has no entry, dense where the damping is
  // (a few coordinates: LinearStructure's choice for its K0).
  std::shared_ptr<const SparseRowMajor> frame_stiffness;
  std::shared_ptr<const Eigen::MatrixXd> dense_frame_stiffness;

  void keep_frame_stiffness(const SparseColMajor& k) {
    SparseRowMajor kept(k);
    kept.prune(0.0);
    if (kept.nonZeros() == 0) return;
    if (Base::dense_stiffness) dense_frame_stiffness = std::make_shared<const Eigen::MatrixXd>(kept);
    else frame_stiffness = std::make_shared<const SparseRowMajor>(std::move(kept));
  }

  // g = K q - f. (A sparse product inside a larger expression goes through a heap temporary: two statements.)
  void frame_gradient(const Vec& q, Vec& g) const {
    if (!dense_frame_stiffness && !frame_stiffness) {  // a frame of springs alone: one pass
      g.noalias() = -Base::force;
      return;
    }
    if (dense_frame_stiffness) g.noalias() = dense_frame_stiffness->lazyProduct(q);
    else g.noalias() = *frame_stiffness * q;
    g -= Base::force;
  }

  double springs_energy(const Vec& q) const {
    double sum = 0.0;
    springs.for_each([&](const auto& set) { sum += set.energy_correction(q); });
    return sum;
  }
};

}  // namespace raydamp
