// Newmark's average acceleration (methods/newmark.hpp) on a Structure with hysteretic springs,
//   M q'' + C q' + R(q) = P(t),   R(q) = K0 q - f + sum_s r_s (sigma_s(d_s) - k_s d_s)   (grad V),
// C = alpha M + beta K0 (the initial stiffness's Rayleigh damping), p = M v. With gamma = 1/2 and
// beta = 1/4 a step is the trapezoidal rule on both halves,
//   q1 = q0 + h/2 (v0 + v1),   p1 = p0 + h/2 (F0 + F1),   F = P(t) - C v - R(q),
// the form OpenSees' Newmark takes (its a_n is M^{-1} F_n, the equation of motion at each step end, held
// there to the Newton tolerance; here F0 is evaluated at the step's start, so no M^{-1} a is carried).
// With D = q1 - q0, v1 = (2/h) D - v0 and M v1 = (2/h) M D - p0, one equation in D:
//   r(D) = F0 + P1 - C v1 - R(q0 + D) - (2/h) (M v1 - p0) = 0,
//   -dr/dD = (4/h^2) M + (2/h) C + K_t = (4/h^2) (A + (h^2/4) sum_s (k_t,s - k_s) r_s r_s^T),
// A = M + (h/2) C + (h^2/4) K0: the implicit midpoint's matrix (implicit/linear_implicit_factors.hpp),
// factorised once per run (once for an ensemble's members), and the springs' consistent tangents k_t,s
// (the derivative of each return map from the committed state) a correction of rank m, the springs off
// their initial stiffness. By Woodbury, with Z = A^{-1} R (R = [r_s], made once per run) and E the m x m
// matrix diag(4 / (h^2 (k_t,s - k_s))) + R_a^T Z_a, a Newton step is one sparse solve and one dense m x m
// solve: x = A^{-1} r, x -= Z_a E^{-1} (Z_a^T r), dD = (h^2/4) x. Between kinks R is linear, so Newton ends
// in one step on the right branch; across them each iteration picks the branch of its iterate, and a step
// that raises |r| is halved (at most kHalvings times). A step that does not converge in kMaxIterations
// leaves a non-finite state, which the step loop finds by replaying its block (integrate.hpp), and the
// run's report names the step and the reason: integrate_model below turns that into not_converged.
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "raydamp/attributes.hpp"
#include "raydamp/ensemble/driver.hpp"
#include "raydamp/implicit/linear_implicit_factors.hpp"
#include "raydamp/methods/composition.hpp"
#include "raydamp/methods/newmark.hpp"
#include "raydamp/models/structure.hpp"
#include "raydamp/run_types.hpp"

namespace raydamp {

namespace detail {

// The derivative of the return map sigma(d) from the committed state c (t: its trial state at d).
inline double consistent_tangent(const materials::ElasticPlastic& m, const materials::ElasticPlastic::State& c,
                                 const materials::ElasticPlastic::State& t, double) {
  return materials::flowed(c, t) ? 0.0 : m.k;
}
inline double consistent_tangent(const materials::Bilinear& m, const materials::Bilinear::State& c,
                                 const materials::Bilinear::State& t, double) {
  return materials::flowed(c, t) ? m.b * m.k : m.k;
}
// Bouc-Wen's z(d) follows dz/dd = (1/d_y) (1 - (beta sgn(z dd) + gamma) |z|) along the drift from c.d, so
// the end point's derivative is that rate at the end.
inline double consistent_tangent(const materials::BoucWen& m, const materials::BoucWen::State& c,
                                 const materials::BoucWen::State& t, double d) {
  const double direction = d >= c.d ? 1.0 : -1.0;
  const double shape = t.z * direction >= 0.0 ? m.beta + m.gamma : m.beta - m.gamma;
  return m.elastic + (1.0 - m.alpha) * m.k * (1.0 - shape * std::abs(t.z));
}

// The Newton iteration of one run, for either mass kind: it reads the structure's K0, f, M and C through
// the implicit methods' LinearSystem and its springs through the run's own copy; scratch sized once.
class NewmarkCore {
 public:
  static constexpr int kMaxIterations = 50, kHalvings = 8;
  static constexpr double kTolerance = 1e-12;  // |dD| <= kTolerance max(|D|, |q0|), infinity norms

  RAYDAMP_OUT_OF_LINE NewmarkCore(std::shared_ptr<const LinearImplicitFactors> factors,
                                  const materials::Springs& springs)
      : factors_(std::move(factors)), sys_(factors_->system()), springs_(&springs) {
    const Eigen::Index n = sys_.mass.rows();
    for (Eigen::VectorXd* v : {&d_, &q_, &r_, &f0_, &v1_, &mv_, &product_, &load_, &x_, &work_, &step_, &v0_})
      v->resize(n);
    springs.for_each([&](const auto& set) {
      for (std::size_t s = 0; s < set.size(); ++s) {
        from_.push_back(set.i[s]);
        to_.push_back(set.j[s]);
      }
    });
    const Eigen::Index m = static_cast<Eigen::Index>(to_.size());
    tangent_drop_.resize(m);
    active_.reserve(m);
    small_.resize(m, m);
    rhs_.resize(m);
  }

  // Z = A^{-1} R and R^T Z for the factor of sub-step s: once per run and length.
  RAYDAMP_OUT_OF_LINE void prepare(const ImplicitFactor<double>& f) {
    if (prepared_ == &f) return;
    const Eigen::Index n = sys_.mass.rows(), m = static_cast<Eigen::Index>(to_.size());
    z_.resize(n, m);
    for (Eigen::Index s = 0; s < m; ++s) {
      x_.setZero();
      x_[to_[s]] = 1.0;
      if (from_[s] >= 0) x_[from_[s]] = -1.0;
      f.solver.solve(x_, product_, work_);
      z_.col(s) = product_;
    }
    gram_.resize(m, m);
    for (Eigen::Index a = 0; a < m; ++a)
      for (Eigen::Index b = 0; b < m; ++b) gram_(a, b) = spring_dot(b, z_.col(a));
    prepared_ = &f;
  }

  // Scratch for v0 = M^{-1} p, which the caller fills (the mass kind's solve).
  Eigen::VectorXd& velocity() { return v0_; }

  // One step of length f.s from (q, p) at time t, v0 = M^{-1} p given. Returns "" or why it failed (q, p
  // then untouched).
  RAYDAMP_OUT_OF_LINE std::string step(const ImplicitFactor<double>& f, Eigen::VectorXd& q, Eigen::VectorXd& p,
                                       const Eigen::VectorXd& v0, const Load* load, double t) {
    prepare(f);
    const double h = f.s, two_h = 2.0 / h;
    // F0 = P0 - C v0 - R(q0), and the load at the step's end, which every residual adds.
    restoring(q, f0_);
    f0_ = -f0_;
    damping_force(v0, product_);
    f0_ -= product_;
    if (load) {
      load->add(t, 1.0, f0_.data());
      load_.setZero();
      load->add(t + h, 1.0, load_.data());
      f0_ += load_;
    }
    const double scale = q.lpNorm<Eigen::Infinity>();
    d_.setZero();
    double norm = residual(q, p, v0, two_h);
    for (int iteration = 0; iteration < kMaxIterations; ++iteration) {
      if (!std::isfinite(norm)) return "its residual is not finite";
      newton_step(f, h);  // step_ = dD at the iterate's tangent
      const double size = step_.lpNorm<Eigen::Infinity>();
      if (!std::isfinite(size)) return "its Newton step is not finite";
      double lambda = 1.0, next = 0.0;
      for (int k = 0;; ++k) {  // halve a step that raises |r|, unless it is within the tolerance
        d_ += lambda * step_;
        next = residual(q, p, v0, two_h);
        if (next < norm || k == kHalvings || lambda * size <= kTolerance * std::max(d_.lpNorm<Eigen::Infinity>(), scale))
          break;
        d_ -= lambda * step_;
        lambda *= 0.5;
      }
      norm = next;
      if (lambda * size <= kTolerance * std::max(d_.lpNorm<Eigen::Infinity>(), scale)) {
        // Converged; the springs' trial states are those at q0 + D (the last residual's).
        p = mv_ - p;  // p1 = M v1 = (2/h) M D - p0: mv_ holds (2/h) M D
        q += d_;
        return "";
      }
    }
    std::ostringstream why;
    why.precision(3);
    why << "Newton's iteration did not converge in " << kMaxIterations << " iterations (last |dq| relative to "
        << "max(|D|, |q0|): " << step_.lpNorm<Eigen::Infinity>() / std::max(d_.lpNorm<Eigen::Infinity>(), scale)
        << ", tolerance " << kTolerance << ")";
    return why.str();
  }

 private:
  // out = R(q) = K0 q - f + the springs' corrections (writing their trial states from the committed ones).
  void restoring(const Eigen::VectorXd& q, Eigen::VectorXd& out) {
    out.noalias() = *sys_.stiffness * q;
    out -= sys_.force;
    springs_->for_each([&](const auto& set) { set.template add_forces<true>(q, out); });
  }

  // out = C v = alpha M v + beta K0 v.
  void damping_force(const Eigen::VectorXd& v, Eigen::VectorXd& out) {
    out.noalias() = sys_.mass * v;
    out *= sys_.alpha;
    if (sys_.beta != 0.0) out.noalias() += sys_.beta * (*sys_.stiffness * v);
  }

  // r_ = r(D) at q0 + D, with mv_ = (2/h) M D, the springs' tangent drops and active set at the iterate;
  // returns |r|_2.
  double residual(const Eigen::VectorXd& q0, const Eigen::VectorXd& p0, const Eigen::VectorXd& v0, double two_h) {
    q_ = q0 + d_;
    restoring(q_, r_);
    r_ = f0_ - r_;
    mv_.noalias() = sys_.mass * d_;
    mv_ *= two_h;
    // -C v1 - (2/h) (M v1 - p0) with v1 = (2/h) D - v0 and M v1 = mv_ - p0.
    v1_ = two_h * d_ - v0;
    damping_force(v1_, product_);
    r_ -= product_;
    r_ -= two_h * (mv_ - 2.0 * p0);
    active_.clear();
    std::size_t s = 0;
    springs_->for_each([&](const auto& set) {
      for (std::size_t k = 0; k < set.size(); ++k, ++s) {
        const double d = set.deformation(q_, k);
        const double drop = consistent_tangent(set.material[k], set.committed[k], set.trial[k], d) -
                            set.material[k].stiffness();
        tangent_drop_[static_cast<Eigen::Index>(s)] = drop;
        if (drop != 0.0) active_.push_back(static_cast<int>(s));
      }
    });
    return r_.norm();
  }

  // step_ = (h^2/4) (A + (h^2/4) R_a diag(drop) R_a^T)^{-1} r_, by Woodbury over the active springs.
  void newton_step(const ImplicitFactor<double>& f, double h) {
    const double c = 0.25 * h * h;
    f.solver.solve(r_, x_, work_);
    const int m = static_cast<int>(active_.size());
    if (m > 0) {
      for (int a = 0; a < m; ++a) {
        rhs_[a] = spring_dot(active_[a], x_);
        for (int b = 0; b < m; ++b) small_(a, b) = gram_(active_[a], active_[b]);
        small_(a, a) += 1.0 / (c * tangent_drop_[active_[a]]);
      }
      solve_small(m);
      for (int a = 0; a < m; ++a) x_ -= rhs_[a] * z_.col(active_[a]);
    }
    step_ = c * x_;
  }

  // r_s^T x.
  template <class X>
  double spring_dot(Eigen::Index s, const X& x) const {
    return from_[s] < 0 ? x[to_[s]] : x[to_[s]] - x[from_[s]];
  }

  // rhs_ <- small_^{-1} rhs_ over its leading m x m block: Gaussian elimination with partial pivoting (E is
  // negative definite when the tangent stiffness is positive definite, but a softening spring's need not be).
  void solve_small(int m) {
    for (int k = 0; k < m; ++k) {
      int pivot = k;
      for (int i = k + 1; i < m; ++i)
        if (std::abs(small_(i, k)) > std::abs(small_(pivot, k))) pivot = i;
      if (pivot != k) {
        for (int j = 0; j < m; ++j) std::swap(small_(k, j), small_(pivot, j));
        std::swap(rhs_[k], rhs_[pivot]);
      }
      const double diagonal = small_(k, k);
      for (int i = k + 1; i < m; ++i) {
        const double l = small_(i, k) / diagonal;
        if (l == 0.0) continue;
        for (int j = k; j < m; ++j) small_(i, j) -= l * small_(k, j);
        rhs_[i] -= l * rhs_[k];
      }
    }
    for (int k = m - 1; k >= 0; --k) {
      double sum = rhs_[k];
      for (int j = k + 1; j < m; ++j) sum -= small_(k, j) * rhs_[j];
      rhs_[k] = sum / small_(k, k);
    }
  }

  std::shared_ptr<const LinearImplicitFactors> factors_;
  const LinearSystem& sys_;  // factors_'s
  const materials::Springs* springs_;
  std::vector<int> from_, to_;  // each spring's coordinates, Springs' order
  const ImplicitFactor<double>* prepared_ = nullptr;
  Eigen::MatrixXd z_, gram_, small_;
  Eigen::VectorXd d_, q_, r_, f0_, v1_, mv_, product_, load_, x_, work_, step_, v0_, tangent_drop_, rhs_;
  std::vector<int> active_;
};

}  // namespace detail

// The steps of one run of newmark on a Structure with springs: whole steps only, the last of h_last.
// Refused, naming the argument: a composition, located kinks, a tangent-stiffness damping.
class NewmarkStepper {
 public:
  template <class Model>
  NewmarkStepper(const Model& model, const Composition& composition, const RunSpec& spec)
      : last_step_(spec.n_steps - 1), h_(spec.h) {
    std::shared_ptr<const LinearImplicitFactors> factors = spec.implicit_factors;
    if (!factors) factors = prepare(model, composition, spec);
    if (!factors->system().describes(model))
      throw std::logic_error("implicit_factors: made for another structure than the run's");
    regular_ = factors->find<double>(spec.h);
    last_ = factors->find<double>(spec.h_last);
    if (!regular_ || !last_) throw std::logic_error("implicit_factors: no factor of newmark's step");
    report_ = &model.implicit_failure;
    core_ = std::make_shared<detail::NewmarkCore>(std::move(factors), model.springs);
  }

  // The factor of A = M + (h/2) C + (h^2/4) K0 for h and h_last, each made once (an ensemble's, for all the
  // members of one structure).
  template <class Model>
  static std::shared_ptr<const LinearImplicitFactors> prepare(const Model& model, const Composition& composition,
                                                             const RunSpec& spec) {
    if (composition.stages() != 1)
      throw std::invalid_argument("composition: '" + composition.name() + "' composes a symmetric order-2 step, and "
                                  "'newmark' is not composed (its springs commit once per step); use 3s with a "
                                  "composition for a higher order");
    if (model.springs.phased())
      throw std::invalid_argument("locate_kinks: 'newmark' steps whole steps (Newton across a kink, as OpenSees); "
                                  "use 3s, 2s, rks or baoab to locate kinks");
    if (model.damping.tangent())
      throw std::invalid_argument("damping_stiffness: 'newmark' takes the initial stiffness's damping "
                                  "(C = alpha M + beta K0); 'tangent' runs with 3s, 2s, rks or baoab");
    auto factors = std::make_shared<LinearImplicitFactors>(detail::LinearSystem(model));
    for (const double h : {spec.h, spec.h_last}) factors->make<double>(h, 0.5);
    return factors;
  }

  template <class Model, class Tab, int Dim, class WS>
  void step(const Model& model, const Tab&, State<Dim>& z, long i, WS& ws) const {
    const detail::ImplicitFactor<double>& f = *(i == last_step_ ? last_ : regular_);
    Eigen::VectorXd& v0 = core_->velocity();
    model.mass.velocity(z.p, v0);
    const std::string failed = core_->step(f, z.q, z.p, v0, ws.load, ws.time);
    ws.time += f.s;
    if (failed.empty()) return;
    // The step loop sees a non-finite state, replays the block and stops before this step; the report says why
    // (a step after it in the block starts from that state, and reports nothing).
    if (z.all_finite()) {
      report_->step = i;
      std::ostringstream why;
      why << "newmark: step " << i + 1 << " (t = " << i * h_ << " to " << i * h_ + f.s << "): " << failed
          << "; the state before it is the last row";
      report_->message = why.str();
    }
    z.q.setConstant(std::numeric_limits<double>::quiet_NaN());
    z.p.setConstant(std::numeric_limits<double>::quiet_NaN());
  }

 private:
  std::shared_ptr<detail::NewmarkCore> core_;
  detail::ImplicitFailure* report_ = nullptr;
  long last_step_;
  double h_;
  const detail::ImplicitFactor<double>* regular_ = nullptr;
  const detail::ImplicitFactor<double>* last_ = nullptr;
};

namespace detail {

// integrate_model for newmark: the run's own copy reports the step whose iteration failed, and the run's
// non-finite end there becomes not_converged.
template <class Mass>
RunResult integrate_newmark(const Structure<Mass>& model, const ButcherTableau& tab, const Composition& comp,
                            State<Eigen::Dynamic> z, const RunSpec& spec, const Control& control) {
  const Structure<Mass> own = model.fresh_run();
  RunResult result = integrate<Newmark>(own, tab, comp, std::move(z), spec, control);
  const ImplicitFailure& failure = own.implicit_failure;
  if (result.status == Status::non_finite && failure.step >= 0 && result.failed_step == failure.step + 1) {
    result.status = Status::not_converged;
    result.message = failure.message;
  }
  return result;
}

}  // namespace detail

template <>
inline RunResult integrate_model<Newmark, Structure<LumpedMass>>(const Structure<LumpedMass>& model,
                                                                 const ButcherTableau& tab, const Composition& comp,
                                                                 State<Eigen::Dynamic> z, const RunSpec& spec,
                                                                 const Control& control) {
  return detail::integrate_newmark(model, tab, comp, std::move(z), spec, control);
}

template <>
inline RunResult integrate_model<Newmark, Structure<ConsistentMass>>(const Structure<ConsistentMass>& model,
                                                                     const ButcherTableau& tab,
                                                                     const Composition& comp,
                                                                     State<Eigen::Dynamic> z, const RunSpec& spec,
                                                                     const Control& control) {
  return detail::integrate_newmark(model, tab, comp, std::move(z), spec, control);
}

}  // namespace raydamp
