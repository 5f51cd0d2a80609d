// The Rayleigh damping of a structure with springs (models/structure.hpp): C = alpha M + beta K0 with the
// initial stiffness K0 (the default), or, for damping_stiffness = "tangent",
//   C_t = alpha M + beta K_t,   K_t = K0 - sum_s (k_s - k_t,s) r_s r_s^T,
// k_t,s the tangent of spring s on its branch: k_s elastic, b k_s yielding (0 for ElasticPlastic).
//
// A branch is the set of springs on their yielding branch (a bit mask). On one branch C_t is constant, so
// every damping sub-flow is the exact flow of a constant matrix, made from the branch's modes as the initial
// stiffness's are (M = L L^T, L^{-1} K_t L^{-T} = V Lambda V^T, f(A_t) = L V f(alpha + beta Lambda) V^T L^{-1}):
// one eigendecomposition per branch met, one pair of n x n matrices per branch and sub-step length, cached
// and shared by the runs of one model. Which branch a sub-flow takes:
//   - kinks located (springs.phased()): each spring's phase, which holds over a whole piece of a step, so
//     between two kinks the run is an exact flow of one linear system per sub-flow and the method keeps
//     its order;
//   - otherwise the branch of the last committed step (a spring yielded at that step's last kick), frozen
//     over the next step: a branch change is seen up to a step late, which makes the damping force wrong by
//     beta (k_s - k_t,s) d_s' over at most one step per kink, so the method is of order 1.
// Only where the initial damping's flows are its modes (n <= the dense limit), and for springs whose
// tangent is piecewise constant and not negative (ElasticPlastic, Bilinear with b >= 0) on a K whose
// yielded tangent K_t stays positive semidefinite (no P-Delta softening): the flows are then exact
// decays, never growths. Bouc-Wen's tangent changes continuously and would need a new eigendecomposition
// at every step.
#pragma once

#include <cmath>
#include <cstdint>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include "raydamp/damping/sparse_rayleigh_damping.hpp"
#include "raydamp/materials/springs.hpp"
#include "raydamp/phi.hpp"
#include "raydamp/thread_scratch.hpp"

namespace raydamp {

template <class Mass>
class StructureDamping {
 public:
  using Initial = SparseRayleighDamping<Mass>;
  using Factors = typename Initial::Factors;
  using Series = typename Initial::Series;
  using Modes = typename Initial::Modes;
  static constexpr const char* kNoNoise = Initial::kNoNoise;
  static constexpr int kMaxSprings = 64;  // a branch is a 64-bit mask

  explicit StructureDamping(Initial initial) : initial_(std::move(initial)) {}

  // The springs whose branches the tangent follows: the structure's own (re-attached on every copy).
  void attach(const materials::Springs* springs) { springs_ = springs; }

  // Damp with the tangent stiffness from now on. m, k0: M and the initial stiffness K0, dense; the springs'
  // tangents are checked here (names in the messages are the Python layer's).
  void use_tangent(const Eigen::MatrixXd& m, const Eigen::MatrixXd& k0) {
    const std::string why = "damping_stiffness: 'tangent' ";
    if (!initial_.dense())
      throw std::invalid_argument(why + "is offered for structures of at most " + std::to_string(kMaxDenseDim) +
                                  " coordinates, whose damping flows are made from their modes (one "
                                  "eigendecomposition per branch of the springs); a larger one's Chebyshev flows "
                                  "would need a spectral bound and series per branch");
    if (springs_->size() > static_cast<std::size_t>(kMaxSprings))
      throw std::invalid_argument(why + "takes at most " + std::to_string(kMaxSprings) + " springs");
    if (springs_->bouc_wen.size())
      throw std::invalid_argument(why + "needs springs whose tangent is constant between kinks (ElasticPlastic, "
                                        "Bilinear); a Bouc-Wen spring's changes at every step");
    auto model = std::make_shared<TangentModel>();
    Eigen::LLT<Eigen::MatrixXd> llt(m);
    if (llt.info() != Eigen::Success) throw std::invalid_argument("M: must be positive definite");
    const Eigen::Index n = m.rows();
    model->lower = llt.matrixL();
    model->lower_inverse = llt.matrixL().solve(Eigen::MatrixXd::Identity(n, n));
    model->k0 = k0;
    springs_->for_each([&](const auto& set) {
      for (std::size_t s = 0; s < set.size(); ++s) {
        const double drop = set.material[s].stiffness() - yielded_tangent(set.material[s]);
        if (!(drop <= set.material[s].stiffness()))
          throw std::invalid_argument(why + "needs a post-yield stiffness b k >= 0 (a softening spring's "
                                            "negative tangent would make its damping feed energy in)");
        model->i.push_back(set.i[s]);
        model->j.push_back(set.j[s]);
        model->drop.push_back(drop);
      }
    });
    // Every spring yielded gives the least K_t (a drop of each k_s r_s r_s^T): positive semidefinite there,
    // every branch's damping rates are >= alpha.
    const std::uint64_t all = model->i.size() == 64 ? ~std::uint64_t{0} : (std::uint64_t{1} << model->i.size()) - 1;
    const Eigen::VectorXd lambda = modes_of(*model, all).lambda;
    const double largest = std::max(lambda.cwiseAbs().maxCoeff(), 1e-300);
    if (lambda.minCoeff() < -1e-10 * largest)
      throw std::invalid_argument(why + "needs K + sum_s b k_s r_s r_s^T positive semidefinite (every spring "
                                        "yielded); this K's geometric (P-Delta) softening makes it indefinite, "
                                        "and the damping beta K_t would then feed energy in");
    tangent_ = std::move(model);
    caches_ = std::make_shared<Caches>();
  }

  bool tangent() const { return tangent_ != nullptr; }

  // What the initial damping answers (the bound holds for every branch: K_t <= K0).
  const Initial& initial() const { return initial_; }
  double alpha() const { return initial_.alpha(); }
  double beta() const { return initial_.beta(); }
  double spectral_bound() const { return initial_.spectral_bound(); }
  double rate_bound() const { return initial_.rate_bound(); }
  bool dense() const { return initial_.dense(); }
  const Modes* modes() const { return initial_.modes(); }
  Factors factors(double t) const { return initial_.factors(t); }
  std::shared_ptr<const Series> series(double t) const { return initial_.series(t); }
  std::shared_ptr<const Series> chebyshev(double t) const { return initial_.chebyshev(t); }

  // p <- exp(-t A) p, A the branch's.
  template <class Q, class P>
  void decay(const Q& q, const Factors& f, P& p) const {
    const std::uint64_t mask = branch();
    if (mask == 0) return initial_.decay(q, f, p);
    const Flow& flow = flow_of(mask, f.t);
    Eigen::VectorXd& y = thread_scratch(kScratchSum, p.size());
    y.noalias() = flow.exp.lazyProduct(p);
    p = y;
  }

  // p <- exp(-t A) p - t phi1(-t A) g.
  template <class Q, class G, class P>
  void decay_affine(const Q& q, const Factors& f, const G& g, P& p) const {
    const std::uint64_t mask = branch();
    if (mask == 0) return initial_.decay_affine(q, f, g, p);
    const Flow& flow = flow_of(mask, f.t);
    Eigen::VectorXd& y = thread_scratch(kScratchSum, p.size());
    y.noalias() = flow.exp.lazyProduct(p);
    y.noalias() -= flow.t_phi1.lazyProduct(g);
    p = y;
  }

  // out = A p (the dissipated power p^T M^{-1} A p, an envelope's acceleration).
  template <class Q, class P, class O>
  void rate(const Q& q, const P& p, O& out) const {
    const std::uint64_t mask = branch();
    if (mask == 0) return initial_.rate(q, p, out);
    out.noalias() = branch_of(mask).a * p;
  }

  // x <- (I + cA)^{-1} x (rks with a diagonally implicit tableau).
  template <class Q, class X>
  void solve_shifted(const Q& q, double c, X& x) const {
    const std::uint64_t mask = branch();
    if (mask == 0) return initial_.solve_shifted(q, c, x);
    const Modes& modes = branch_of(mask);
    Eigen::VectorXd& y = thread_scratch(kScratchProduct, x.size());
    y.noalias() = modes.to_modes * x;
    y.array() /= 1.0 + c * modes.rates.array();
    x.noalias() = modes.from_modes * y;
  }

  // A tangent damping has no exact noise flow: its matrix changes with the springs' state.
  bool has_noise() const {
    if (tangent_)
      throw std::invalid_argument("temperature: a Structure with damping_stiffness='tangent' has no exact thermal "
                                  "noise (its damping changes with the springs' state); use 'initial'");
    return initial_.has_noise();
  }
  template <class Q, class M, class X, class P>
  void add_noise(const Q& q, const Factors& f, const M& mass, double sigma, const X& xi, P& p) const {
    has_noise();
    initial_.add_noise(q, f, mass, sigma, xi, p);
  }
  const ChebyshevSeries& noise_series(const Series& s) const { return initial_.noise_series(s); }

 private:
  struct TangentModel {
    Eigen::MatrixXd k0, lower, lower_inverse;
    std::vector<int> i, j;     // each spring's coordinates (i < 0: to the ground), Springs' order
    std::vector<double> drop;  // k_s - its yielded tangent
  };
  struct Branch {
    std::uint64_t mask;
    Modes modes;
  };
  struct Flow {
    std::uint64_t mask;
    double t;
    Eigen::MatrixXd exp, t_phi1;
  };
  // Shared by the copies of one model (its runs); results depend only on (mask, t), so whichever run makes
  // an entry, every run reads the same numbers.
  struct Caches {
    std::mutex mutex;
    std::vector<std::shared_ptr<const Branch>> branches;
    std::vector<std::shared_ptr<const Flow>> flows;
  };
  static constexpr std::size_t kCachedBranches = 256, kCachedFlows = 512, kRecent = 4;

  static double yielded_tangent(const materials::ElasticPlastic&) { return 0.0; }
  static double yielded_tangent(const materials::Bilinear& m) { return m.b * m.k; }
  static double yielded_tangent(const materials::BoucWen& m) { return m.k; }  // refused before

  std::uint64_t branch() const { return tangent_ ? springs_->yield_mask() : 0; }

  // The modes of branch `mask`: M^{-1} K_t with K_t = K0 - the yielded springs' drops.
  Modes modes_of(const TangentModel& model, std::uint64_t mask) const {
    Eigen::MatrixXd k = model.k0;
    for (std::size_t s = 0; s < model.i.size(); ++s) {
      if (!(mask >> s & 1U)) continue;
      const double d = model.drop[s];
      const int i = model.i[s], j = model.j[s];
      k(j, j) -= d;
      if (i >= 0) {
        k(i, i) -= d;
        k(i, j) += d;
        k(j, i) += d;
      }
    }
    const Eigen::MatrixXd sym = model.lower_inverse * k * model.lower_inverse.transpose();
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(0.5 * (sym + sym.transpose()));
    if (eig.info() != Eigen::Success) throw std::runtime_error("the tangent stiffness's eigendecomposition failed");
    Modes out;
    out.from_modes = model.lower * eig.eigenvectors();
    out.to_modes = eig.eigenvectors().transpose() * model.lower_inverse;
    out.lambda = eig.eigenvalues();
    out.rates = (alpha() + beta() * out.lambda.array()).matrix();
    out.a = out.from_modes * out.rates.asDiagonal() * out.to_modes;
    return out;
  }

  const Modes& branch_of(std::uint64_t mask) const {
    if (recent_branch_ && recent_branch_->mask == mask) return recent_branch_->modes;
    std::lock_guard<std::mutex> lock(caches_->mutex);
    recent_branch_ = find_branch(mask);
    return recent_branch_->modes;
  }

  // Under the lock.
  std::shared_ptr<const Branch> find_branch(std::uint64_t mask) const {
    for (const auto& b : caches_->branches)
      if (b->mask == mask) return b;
    auto made = std::make_shared<const Branch>(Branch{mask, modes_of(*tangent_, mask)});
    if (caches_->branches.size() >= kCachedBranches) caches_->branches.erase(caches_->branches.begin());
    caches_->branches.push_back(made);
    return made;
  }

  const Flow& flow_of(std::uint64_t mask, double t) const {
    for (const auto& f : recent_)
      if (f && f->mask == mask && f->t == t) return *f;
    std::shared_ptr<const Flow> found;
    {
      std::lock_guard<std::mutex> lock(caches_->mutex);
      for (const auto& f : caches_->flows)
        if (f->mask == mask && f->t == t) found = f;
      if (!found) {
        const std::shared_ptr<const Branch> b = find_branch(mask);
        auto function = [&](auto fn) {
          Eigen::VectorXd d(b->modes.rates.size());
          for (Eigen::Index k = 0; k < d.size(); ++k) d[k] = fn(b->modes.rates[k]);
          return Eigen::MatrixXd(b->modes.from_modes * d.asDiagonal() * b->modes.to_modes);
        };
        found = std::make_shared<const Flow>(Flow{mask, t, function([t](double r) { return std::exp(-t * r); }),
                                                  function([t](double r) { return t * phi1(-t * r); })});
        if (caches_->flows.size() >= kCachedFlows) caches_->flows.erase(caches_->flows.begin());
        caches_->flows.push_back(found);
      }
    }
    recent_[next_recent_] = found;
    next_recent_ = (next_recent_ + 1) % kRecent;
    return *found;
  }

  Initial initial_;
  const materials::Springs* springs_ = nullptr;
  std::shared_ptr<const TangentModel> tangent_;  // null: the initial stiffness's damping
  std::shared_ptr<Caches> caches_;
  // A run's last flows and branch (each run steps its own copy): most sub-flows find theirs here, unlocked.
  mutable std::shared_ptr<const Flow> recent_[kRecent];
  mutable std::size_t next_recent_ = 0;
  mutable std::shared_ptr<const Branch> recent_branch_;
};

}  // namespace raydamp
