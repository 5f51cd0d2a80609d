// The steps of the implicit methods of methods/linear_implicit.hpp on a
// LinearStructure: M q'' + C q' + K q = f, C = alpha M + beta K, p = M q'.
//
// In first-order form y = (q, v), y' = A y + b. A Gauss method with s stages applied
// to it gives y1 = y0 + h Q(hA)^{-1} (A y0 + b) (R(z) - 1 = z / Q(z) for the diagonal
// Pade approximant R = P / Q). For s = 1, Q(z) = 1 - z/2; for s = 2, Q(z) = (z - mu)
// (z - conj mu) / 12 with mu = 3 + i sqrt(3), and by partial fractions
// Q(z)^{-1} = 2 Re[(2 sqrt(3) i / mu) (1 - z / mu)^{-1}]. Each factor (I - c A)^{-1},
// c = h lambda (lambda = 1/2, or 1/mu), reduces to one n x n solve: writing
// (I - cA) w = A y0 + b with w = (u, .), the velocity part u solves
//     (M + c C + c^2 K) u = p0 + c (f - K q0)                                  (*)
// with no M^{-1} anywhere, and then
//   midpoint (u = vbar, the midpoint velocity):  q1 = q0 + h u,  p1 = 2 M u - p0;
//   gauss4:  q1 = q0 - 4 sqrt(3) h Im(lambda u),  p1 = p0 - 4 sqrt(3) M Im(u).
// u is also the stage velocities: V = u (midpoint), V_i = Re u - g_i Im u with
// g_{1,2} = sqrt(3) -+ 2 (gauss4; K_i = 2 Re(kappa_i w) from the eigenvectors of the
// Butcher matrix), so the damping work of a step, h sum_i b_i V_i^T C V_i, is the
// method's own: H(z1) - H(z0) + W_step = 0 to rounding (H with the load's potential).
//
// The matrix of (*) is factorised once per distinct sub-step length (a run has one,
// two with a shortened last step, more for a composition) before the first step, once
// for all the members of an ensemble (implicit/linear_implicit_factors.hpp):
// real SPD for the midpoint, complex symmetric with an SPD real part for gauss4
// (Re(c) > 0, Re(c^2) > 0), both by SparseLDLT over one shared analysis.
// A time-dependent load f(t) (load.hpp) enters (*) as f~, the stage forces weighted by
// the left eigenvector of the Butcher matrix for lambda (the transformation that gives
// the partial fractions above, applied to stage-dependent b_i; the weights sum to one):
//   midpoint: f~ = f(t + h/2);
//   gauss4:   f~ = (f_1 - i k f_2) / (1 - i k), k = 2 - sqrt(3), f_i = f(t + c_i h),
//             c_{1,2} = 1/2 -+ sqrt(3)/6.
// Everything after the solve reads only u, so q1, p1 and V_i keep their formulas, and
// the load's work h sum_i b_i f_i^T V_i balances the energy to rounding as the damping's does.
#pragma once

#include <array>
#include <cmath>
#include <complex>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "raydamp/amplification.hpp"
#include "raydamp/catalogue.hpp"
#include "raydamp/implicit/linear_implicit_factors.hpp"
#include "raydamp/integrate.hpp"
#include "raydamp/load.hpp"
#include "raydamp/methods/linear_implicit.hpp"
#include "raydamp/models/linear_structure.hpp"
#include "raydamp/state.hpp"
#include "raydamp/workspace.hpp"

namespace raydamp {

namespace detail {

// The largest factor by which one backward implicit-midpoint sub-step of length s < 0
// multiplies a mode (|R(s lambda)|, R(z) = (1 + z/2) / (1 - z/2), lambda an eigenvalue
// of the mode's [[0, 1], [-w^2, -(alpha + beta w^2)]]), over w^2 in [0, L]: the
// composition's counterpart of amplification.hpp's bound.
inline double backward_midpoint_amplification(const LinearSystem& sys, double s) {
  double worst = 1.0;
  auto mode = [&](double w2) {
    const double c = sys.alpha + sys.beta * w2;
    const std::complex<double> root = std::sqrt(std::complex<double>(c * c - 4.0 * w2, 0.0));
    for (const std::complex<double> lambda : {0.5 * (-c + root), 0.5 * (-c - root)}) {
      const std::complex<double> z = s * lambda;
      worst = std::max(worst, std::abs((1.0 + 0.5 * z) / (1.0 - 0.5 * z)));
    }
  };
  mode(0.0);
  constexpr int kSamples = 400;
  for (int i = 0; i <= kSamples; ++i) mode(sys.spectral_bound * std::pow(10.0, -12.0 * (1.0 - double(i) / kSamples)));
  return worst;
}

// The step of Method over a sub-step of length s with its factor, in scratch of its own:
// one per run (an ensemble's member), over factors any number of runs share.
template <class Method>
class LinearImplicitCore {
 public:
  static constexpr bool is_complex = std::is_same_v<Method, Gauss4>;
  using Scalar = std::conditional_t<is_complex, std::complex<double>, double>;
  using ScalarVector = Eigen::Matrix<Scalar, Eigen::Dynamic, 1>;
  // lambda: the eigenvalue of the Butcher matrix, 1/2 or 1/mu = (3 - i sqrt 3) / 12.
  static Scalar lambda() {
    if constexpr (is_complex) return Scalar(3.0, -std::sqrt(3.0)) / 12.0;
    else return 0.5;
  }

  // Scratch sized once (the step loop allocates nothing); the factors are shared, read-only.
  explicit LinearImplicitCore(std::shared_ptr<const LinearImplicitFactors> factors)
      : factors_(std::move(factors)), sys_(factors_->system()) {
    const Eigen::Index n = sys_.mass.rows();
    kq_.resize(n);
    real_.resize(n);
    product_.resize(n);
    rhs_.resize(n);
    u_.resize(n);
    work_.resize(n);
    load_.resize(n);
  }

  // z <- one step of length f.s from time t; adds the step's damping work to *work and
  // the load's to *load_work if given.
  void step(const ImplicitFactor<Scalar>& f, Eigen::VectorXd& q, Eigen::VectorXd& p, double* work,
            const Load* load, double t, double* load_work) {
    const double s = f.s;
    const Scalar c = Scalar(s) * lambda();
    kq_.noalias() = *sys_.stiffness * q;
    real_ = sys_.force - kq_;
    rhs_ = p.cast<Scalar>() + c * real_.cast<Scalar>();  // (*)'s right side
    if (load) {
      if constexpr (!is_complex) {
        load_.setZero();
        load->add(t + 0.5 * s, 1.0, load_.data());
        rhs_ += c * load_;
      } else {
        const double k = 2.0 - std::sqrt(3.0);
        const Scalar w1 = Scalar(1.0) / Scalar(1.0, -k), w2 = Scalar(0.0, -k) / Scalar(1.0, -k);
        for (int i = 0; i < 2; ++i) {
          load_.setZero();
          load->add(t + stage_c(i) * s, 1.0, load_.data());
          rhs_ += (c * (i == 0 ? w1 : w2)) * load_.template cast<Scalar>();
        }
      }
    }
    f.solver.solve(rhs_, u_, work_);
    if constexpr (!is_complex) {
      q += s * u_;
      product_.noalias() = sys_.mass * u_;
      p = 2.0 * product_ - p;
      if (work) *work += s * damping_power(u_);
      if (load && load_work) *load_work += s * load->dot(t + 0.5 * s, u_.data());
    } else {
      const double k = 4.0 * std::sqrt(3.0);
      real_ = (lambda() * u_).imag();
      q -= (k * s) * real_;
      real_ = u_.imag();
      product_.noalias() = sys_.mass * real_;
      p -= k * product_;
      if (work) {
        // b_1 = b_2 = 1/2; V_i = Re u - g_i Im u.
        double w = 0.0;
        for (const double g : {std::sqrt(3.0) - 2.0, std::sqrt(3.0) + 2.0}) {
          real_ = u_.real() - g * u_.imag();
          w += 0.5 * damping_power(real_);
        }
        *work += s * w;
      }
      if (load && load_work) {
        double w = 0.0;
        for (int i = 0; i < 2; ++i) {
          real_ = u_.real() - stage_g(i) * u_.imag();
          w += 0.5 * load->dot(t + stage_c(i) * s, real_.data());
        }
        *load_work += s * w;
      }
    }
  }

 private:
  // v^T C v = alpha v^T M v + beta v^T K v.
  double damping_power(const Eigen::VectorXd& v) {
    double out = 0.0;
    if (sys_.alpha != 0.0) {
      product_.noalias() = sys_.mass * v;
      out += sys_.alpha * v.dot(product_);
    }
    if (sys_.beta != 0.0) {
      kq_.noalias() = *sys_.stiffness * v;
      out += sys_.beta * v.dot(kq_);
    }
    return out;
  }

  // The Gauss nodes c_i and the g_i of V_i = Re u - g_i Im u, stage by stage.
  static double stage_c(int i) { return 0.5 + (i == 0 ? -1.0 : 1.0) * std::sqrt(3.0) / 6.0; }
  static double stage_g(int i) { return std::sqrt(3.0) + (i == 0 ? -2.0 : 2.0); }

  std::shared_ptr<const LinearImplicitFactors> factors_;
  const LinearSystem& sys_;  // factors_'s
  Eigen::VectorXd kq_, real_, product_, load_;
  ScalarVector rhs_, u_, work_;
};

}  // namespace detail

// The steps of one run of Method (ImplicitMidpoint or Gauss4) on a linear structure:
// each step is the composition's sub-steps gamma_j h (one sub-step of h uncomposed),
// the last step's of h_last. The factors are spec.implicit_factors when given (an
// ensemble's, made once by prepare() for all its members), else the run's own. Copied
// once per block of steps by the step loop: it holds only the sub-step table and a
// shared pointer to the run's scratch, which points to the factors.
template <class Method>
class LinearImplicitStepper {
 public:
  using Core = detail::LinearImplicitCore<Method>;
  using Scalar = typename Core::Scalar;

  template <class Model>
  LinearImplicitStepper(const Model& model, const Composition& composition, const RunSpec& spec)
      : last_step_(spec.n_steps - 1), stages_(composition.stages()) {
    std::shared_ptr<const LinearImplicitFactors> factors = spec.implicit_factors;
    if (!factors) factors = prepare(model, composition, spec);
    if (!factors->system().describes(model))
      throw std::logic_error("implicit_factors: made for another structure than the run's");
    for (int j = 0; j < stages_; ++j) {
      regular_[j] = made(*factors, composition.gamma(j) * spec.h);
      last_[j] = made(*factors, composition.gamma(j) * spec.h_last);
    }
    core_ = std::make_shared<Core>(std::move(factors));
  }

  // The factors of every sub-step length of a run of spec (gamma_j h and gamma_j h_last),
  // each made once; refused as checked() says.
  template <class Model>
  static std::shared_ptr<const LinearImplicitFactors> prepare(const Model& model, const Composition& composition,
                                                             const RunSpec& spec) {
    static_assert(is_linear_system<Model>::value, "the linear implicit methods run a LinearStructure");
    auto factors = std::make_shared<LinearImplicitFactors>(detail::LinearSystem(model));
    for (int j = 0; j < composition.stages(); ++j)
      for (const double h : {spec.h, spec.h_last}) checked(*factors, composition, composition.gamma(j) * h);
    return factors;
  }

  template <class Model, class Tab, int Dim, class WS>
  void step(const Model&, const Tab&, State<Dim>& z, long i, WS& ws) const {
    const auto& sub = i == last_step_ ? last_ : regular_;
    double* work = ws.track_work ? &ws.work : nullptr;
    double* load_work = ws.track_work ? &ws.load_work : nullptr;
    for (int j = 0; j < stages_; ++j) {
      core_->step(*sub[j], z.q, z.p, work, ws.load, ws.time, load_work);
      ws.time += sub[j]->s;
    }
  }

 private:
  static const detail::ImplicitFactor<Scalar>* made(const LinearImplicitFactors& factors, double s) {
    const detail::ImplicitFactor<Scalar>* f = factors.find<Scalar>(s);
    if (!f) throw std::logic_error(std::string("implicit_factors: no factor of ") + Method::name + "'s sub-step");
    return f;
  }

  // Makes the factor of a sub-step of length s; a backward one (a composition's negative
  // coefficient) only where its matrix stays positive definite and it amplifies no
  // mode past kMaxAmplification.
  static void checked(LinearImplicitFactors& factors, const Composition& composition, double s) {
    const detail::ImplicitFactor<Scalar>* f = factors.make<Scalar>(s, Core::lambda());
    if constexpr (std::is_same_v<Scalar, double>) {
      if (s >= 0.0) return;
      const detail::LinearSystem& sys = factors.system();
      std::ostringstream why;
      why.precision(3);
      why << "composition: '" << composition.name() << "' over '" << Method::name
          << "' runs backward sub-steps (s = " << s << ", coefficient " << composition.min_gamma()
          << " of h), each solving with M + (s/2) C + (s^2/4) K = (1 - |s| alpha/2) M + (s^2/4 - |s| beta/2) K";
      if (!f->solver.positive_pivots()) {
        why << ", which is not positive definite here (alpha = " << sys.alpha << ", beta = " << sys.beta
            << (sys.beta > 0.0 ? "; with beta K damping the K term is negative once |s| < 2 beta" : "")
            << "): the backward step has a pole in the structure's spectrum; use the order-2 method "
               "(composition=None), method 'gauss4' (order 4), or "
            << (sys.beta > 0.0 ? "a structure with beta = 0" : "a smaller h");
        throw std::invalid_argument(why.str());
      }
      const double bound = detail::backward_midpoint_amplification(sys, s);
      if (bound > kMaxAmplification) {
        why << ", which amplifies a damped mode by up to " << bound << " per backward sub-step, past the limit "
            << kMaxAmplification << "; use the order-2 method (composition=None), method 'gauss4' (order 4), "
            << "or a smaller h";
        throw std::invalid_argument(why.str());
      }
    }
  }

  std::shared_ptr<Core> core_;
  long last_step_;
  int stages_;
  std::array<const detail::ImplicitFactor<Scalar>*, kMaxCompositionStages> regular_{}, last_{};
};

}  // namespace raydamp
