// A user's system (python/raydamp/systems/system): H = 1/2 p^T M^{-1} p + V(q) with V, its
// gradient, its Hessian-vector product and the momentum maps compiled at run time
// from expressions, a constant mass kind and a damping kind. One struct for every
// system of a kind: the bindings instantiate each (Mass, Damping) pair once, and a
// new system is new data, never new C++.
#pragma once

#include <array>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

#include "raydamp/concepts.hpp"
#include "raydamp/damping/damper_damping.hpp"
#include "raydamp/state.hpp"
#include "raydamp/system/compiled_function.hpp"

namespace raydamp {

struct SystemFunctions {
  CompiledFunction potential;        // q -> V(q)                      (1 output)
  CompiledFunction gradient;         // q -> grad V(q)                 (n outputs)
  CompiledFunction hessian_product;  // (q, v) -> Hess V(q) v          (n outputs)
  CompiledFunction momenta;          // (q, p) -> J(q, p)              (m outputs; unset when m = 0)
  // (q, p, k, t0, t1, t2) -> (q, p) after 3s's damp exp(-t eps D M^{-1}) p = p - k P(q, p)
  // of the one dashpot with a constant norm, then its body: drift t0, kick t1, drift t2.
  // Derived from the 3s table (python/raydamp/system/compile.py, fused_body): the inputs
  // after (q, p) are the join's damp factor, then the inner sub-flows' durations in table order.
  // Optional: the merged 3s loop then makes one call per step where it made two in
  // series (projection, then gradient), so the step's serial chain crosses one call
  // (the momenta's call depends on nothing later and overlaps).
  CompiledFunction damp_then_3s_body;  // (2n + 4 in, 2n out; unset: the sub-flows one by one)
};

// Dim: Dynamic as bound (one struct for every n); fixed<N>() gives the same system
// with n fixed at compile time, for the step loop of a small system (the bindings
// choose it once per run, outside the loop).
template <class Mass, class Damping, int Dim = Eigen::Dynamic>
struct CompiledSystem {
  static constexpr int dim = Dim;
  static constexpr int n_momenta = kDynamicMomenta;
  // Not flattened even at a fixed n (integrate.hpp, flattens_step_loop): a step crosses
  // the compiled functions' opaque calls either way, and flattening measured no gain
  // (benchmarks/bench_system.py, elastic pendulum: 3s 36 ns/step both ways, 2s 31 -> 30)
  // for three times the compile time of each kind (dashpots: 130 s -> 42 s).
  static constexpr bool flatten_step_loop = false;
  using Vec = Vector<dim>;

  double eps;
  Mass mass;
  Damping damping;
  SystemFunctions functions;
  int n;
  int m;  // number of momentum maps

  CompiledSystem(int n_, double eps_, Mass mass_, Damping damping_, SystemFunctions functions_, int m_)
      : eps(eps_), mass(std::move(mass_)), damping(std::move(damping_)), functions(functions_), n(n_), m(m_) {
    if (n < 1) throw std::invalid_argument("coordinates: a system needs at least one coordinate");
    if (!functions.potential || !functions.gradient || !functions.hessian_product)
      throw std::invalid_argument("potential: not compiled");
    if (m > 0 && !functions.momenta) throw std::invalid_argument("momenta: not compiled");
    if (functions.damp_then_3s_body) {
      bool projects = false;
      if constexpr (std::is_same_v<Damping, DamperDamping>) projects = damping.projects();
      if (!projects)
        throw std::invalid_argument("damping.dampers: a fused 3s body needs one dashpot with a compiled projection");
    }
  }

  // The same system (the same compiled functions, mass and damping) with n == N
  // fixed at compile time: Eigen then unrolls every vector operation of a step.
  template <int N>
  CompiledSystem<Mass, Damping, N> fixed() const {
    if (n != N) throw std::invalid_argument("fixed: this system has " + std::to_string(n) + " coordinates");
    return CompiledSystem<Mass, Damping, N>(n, eps, mass, damping, functions, m);
  }

  int size() const { return n; }
  int momentum_count() const { return m; }

  double potential(const Vec& q) const {
    double v;
    functions.potential(&v, q.data());
    return v;
  }

  void gradient(const Vec& q, Vec& g) const { functions.gradient(g.data(), q.data()); }

  // Diagnostics only (the modified Hamiltonian), so a heap buffer is fine here.
  void hessian_product(const Vec& q, const Vec& v, Vec& out) const {
    std::vector<double> in(2 * n);
    std::copy(q.data(), q.data() + n, in.begin());
    std::copy(v.data(), v.data() + n, in.begin() + n);
    functions.hessian_product(out.data(), in.data());
  }

  // 3s's merged steps (composed_step.hpp, join_then_body): the damp of the factors f
  // (a dashpot's k for this length), then drift t[0], kick t[1], drift t[2], in one call.
  bool fuses_3s() const { return static_cast<bool>(functions.damp_then_3s_body); }
  template <class Factors>
  void damp_then_3s_body(Vec& q, Vec& p, const Factors& f, const double* t) const {
    constexpr int kStack = 2 * kMaxDenseDim + 4;
    std::array<double, kStack> in;
    std::array<double, 2 * kMaxDenseDim> out;
    Eigen::Map<Vec>(in.data(), n) = q;  // Eigen copies: no calls to memmove
    Eigen::Map<Vec>(in.data() + n, n) = p;
    if constexpr (std::is_same_v<Damping, DamperDamping>) in[2 * n] = f.at.k1_projected;
    else in[2 * n] = 0.0;  // never called: only a dashpot's system compiles a fused body
    in[2 * n + 1] = t[0];
    in[2 * n + 2] = t[1];
    in[2 * n + 3] = t[2];
    functions.damp_then_3s_body(out.data(), in.data());
    q = Eigen::Map<const Vec>(out.data(), n);
    p = Eigen::Map<const Vec>(out.data() + n, n);
  }

  // Called every step when momenta are tracked: (q, p) go into a stack buffer.
  void momenta(const Vec& q, const Vec& p, double* out) const {
    if (m == 0) return;
    constexpr int kStack = 256;
    if (2 * n <= kStack) {
      std::array<double, kStack> in;
      // Eigen copies: std::copy of a run-time length becomes two calls to memmove.
      Eigen::Map<Vec>(in.data(), n) = q;
      Eigen::Map<Vec>(in.data() + n, n) = p;
      functions.momenta(out, in.data());
    } else {
      std::vector<double> in(2 * n);
      std::copy(q.data(), q.data() + n, in.begin());
      std::copy(p.data(), p.data() + n, in.begin() + n);
      functions.momenta(out, in.data());
    }
  }
};

}  // namespace raydamp
