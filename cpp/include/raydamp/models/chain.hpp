// A one-dimensional lattice: n sites of mass m on a line, neighbours joined by
// bonds of one family (chain_bonds.hpp), optionally each site held by an on-site
// potential U (chain_on_site.hpp), H = sum p_i^2 / 2m + sum_b V(r_b) + sum_i U(q_i) with r_b
// the stretch of bond b (the difference of its sites' displacements, see
// chain_bond_sites for the numbering and the boundaries), damped by dashpots on
// chosen bonds and friction on chosen sites (damping/chain_damping.hpp).
//
// Built for n up to 10^6 and beyond: the kick and the drift are single contiguous
// passes over q and p (the `kick`/`drift` members the exact flows use in place of
// gradient-then-update), the bond family is chosen once per pass (a switch outside
// the loop, so one model type serves every family), and damping touches only the
// damped sites. 3s between two steps (damp, drift, kick, drift) is one pass over the
// state (damp_then_3s_body), with friction on every site folded into it as one
// multiply-add per site, and 2s's kick+damp with such friction is one pass too.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

#include "raydamp/concepts.hpp"
#include "raydamp/damping/chain_damping.hpp"
#include "raydamp/mass/scalar_mass.hpp"
#include "raydamp/models/chain_bonds.hpp"
#include "raydamp/models/chain_on_site.hpp"
#include "raydamp/state.hpp"

namespace raydamp {

struct ChainBonds {
  BondKind kind = BondKind::fput;
  HarmonicBond harmonic;
  FputBond fput;
  TodaBond toda;
  MorseBond morse;
  LennardJonesBond lennard_jones;
  ExpressionBond expression;

  // f(bond) for the chain's family: one branch per call, outside every loop.
  template <class F>
  decltype(auto) visit(F&& f) const {
    switch (kind) {
      case BondKind::harmonic: return f(harmonic);
      case BondKind::fput: return f(fput);
      case BondKind::toda: return f(toda);
      case BondKind::morse: return f(morse);
      case BondKind::lennard_jones: return f(lennard_jones);
      default: return f(expression);
    }
  }
};

struct Chain {
  static constexpr int dim = Eigen::Dynamic;
  static constexpr int n_momenta = kDynamicMomenta;
  using Vec = Vector<dim>;

  double eps;
  ScalarMass mass;
  ChainDamping damping;
  ChainBonds bonds;
  ChainOnSite on_site;
  ChainBoundary boundary;
  int n;
  // Periodic or free, with no on-site friction and no on-site potential (both tie sites to
  // their rest positions): sum p is a momentum map.
  bool conserves_momentum;

  Chain(int n_, ChainBoundary boundary_, ChainBonds bonds_, double m, double eps_, ChainDamping damping_,
        bool site_friction, ChainOnSite on_site_ = {})
      : eps(eps_), mass(m, "mass"), damping(std::move(damping_)), bonds(bonds_), on_site(on_site_),
        boundary(boundary_), n(n_),
        conserves_momentum(boundary_ != ChainBoundary::fixed && !site_friction &&
                           on_site_.kind == OnSiteKind::none) {
    if (n < 2) throw std::invalid_argument("n must be >= 2 (sites of the chain), got " + std::to_string(n));
    if (!(std::isfinite(eps) && eps >= 0.0)) throw std::invalid_argument("eps must be a finite number >= 0");
    if (bonds.kind == BondKind::expression && !(bonds.expression.v && bonds.expression.dv && bonds.expression.d2v))
      throw std::invalid_argument("bond: the expression bond is not compiled");
  }

  int size() const { return n; }
  int momentum_count() const { return conserves_momentum ? 1 : 0; }
  void momenta(const Vec&, const Vec& p, double* out) const {
    if (conserves_momentum) out[0] = p.sum();
  }

  double potential(const Vec& q) const {
    const double bonded = bonds.visit([&](const auto& bond) {
      double sum = 0.0;
      for (int i = 1; i < n; ++i) sum += bond.energy(q[i] - q[i - 1]);
      if (boundary == ChainBoundary::fixed) sum += bond.energy(q[0]) + bond.energy(-q[n - 1]);
      if (boundary == ChainBoundary::periodic) sum += bond.energy(q[0] - q[n - 1]);
      return sum;
    });
    return bonded + on_site.visit([&](const auto& u) {
      double sum = 0.0;
      if constexpr (!std::decay_t<decltype(u)>::none)
        for (int i = 0; i < n; ++i) sum += u.energy(q[i]);
      return sum;
    });
  }

  // op(i, dV/dq_i) for every site, in order. dV/dq_i = V'(r of the bond to its left)
  // - V'(r of the bond to its right) + U'(q_i).
  template <class Op>
  void for_each_gradient(const Vec& q, Op&& op) const {
    bonds.visit([&](const auto& bond) {
      on_site.visit([&](const auto& u) {
        using U = std::decay_t<decltype(u)>;
        if constexpr (U::none) {
          sweep(bond, q.data(), op);
        } else {
          const double* __restrict x = q.data();
          auto with_site = [&op, &u, x](int i, double gi) { op(i, gi + u.force(x[i])); };
          sweep(bond, x, with_site);
        }
      });
    });
  }

  void gradient(const Vec& q, Vec& g) const {
    double* __restrict out = g.data();
    for_each_gradient(q, [out](int i, double gi) { out[i] = gi; });
  }

  // The exact kick p <- p - t grad V(q) in one pass (flows::kick uses it).
  void kick(const Vec& q, Vec& p, double t) const {
    double* __restrict out = p.data();
    for_each_gradient(q, [out, t](int i, double gi) { out[i] -= t * gi; });
  }

  // The exact drift q <- q + t p / m in one pass (flows::drift uses it).
  void drift(Vec& q, const Vec& p, double t) const {
    const double s = t * mass.inverse;
    double* __restrict x = q.data();
    const double* __restrict y = p.data();
    for (int i = 0; i < n; ++i) x[i] += s * y[i];
  }

  // v . A p / m: the dissipated power from the damped sites only (diagnostics.hpp).
  double dissipated_power(const Vec&, const Vec& p) const { return damping.power(p, mass.inverse); }

  // The exact kick+damp flow p <- e^{-tA} p - t phi1(-tA) grad V(q) (flows::kick_damp, t = f.t).
  // With friction on every site (A diagonal) it is one pass, each site's update folded into the
  // kick's sweep; otherwise the gradient into g and the damping's blocks. Both compute
  // ChainDamping::decay_affine's numbers.
  void kick_damp(const Vec& q, Vec& p, const ChainDamping::Factors& f, Vec& g) const {
    const double t = f.t;
    double* __restrict out = p.data();
    if (damping.shape() == ChainDamping::Shape::uniform) {
      const double e = f.exp_m1[0], tp = f.t_phi1_m1[0];
      for_each_gradient(q, [out, e, tp, t](int i, double gi) {
        out[i] = ChainDamping::affine_decay(e, tp, t, out[i], gi);
      });
    } else if (damping.shape() == ChainDamping::Shape::every_site) {
      const double* __restrict e = f.exp_m1.data();
      const double* __restrict tp = f.t_phi1_m1.data();
      for_each_gradient(q, [out, e, tp, t](int i, double gi) {
        out[i] = ChainDamping::affine_decay(e[i], tp[i], t, out[i], gi);
      });
    } else {
      gradient(q, g);
      damping.decay_affine(q, f, g, p);
    }
  }

  // 3s between two regular steps (ComposedStepper::join_then_body): damp for f.t, then drift
  // t[0], kick t[1], drift t[2], in one pass over the state instead of four. Friction on every
  // site is applied inside the pass (one multiply-add per site), any other damping first on
  // its own sites. The same operations on the same numbers as the four sub-flows in turn, so
  // the same result to the last bit (tests/test_chain.cpp).
  bool fuses_3s() const { return true; }
  void damp_then_3s_body(Vec& q, Vec& p, const ChainDamping::Factors& f, const double* t) const {
    const double s1 = t[0] * mass.inverse, s2 = t[2] * mass.inverse;
    if (damping.shape() == ChainDamping::Shape::uniform) {
      fused_3s(q.data(), p.data(), f.exp_m1[0], s1, t[1], s2);
    } else if (damping.shape() == ChainDamping::Shape::every_site) {
      fused_3s(q.data(), p.data(), f.exp_m1.data(), s1, t[1], s2);
    } else {
      damping.decay(q, f, p);
      // p + 0 p is p for every finite p: no third instantiation of the pass for "no damping".
      fused_3s(q.data(), p.data(), 0.0, s1, t[1], s2);
    }
  }

  // (Hess V v)_i = V''(r_left) (v_i - v_left) - V''(r_right) (v_right - v_i).
  void hessian_product(const Vec& q, const Vec& v, Vec& out) const {
    bonds.visit([&](const auto& bond) {
      out.setZero(n);
      auto add_bond = [&](int l, int r) {  // -1: a wall (displacement 0)
        const double ql = l >= 0 ? q[l] : 0.0, qr = r >= 0 ? q[r] : 0.0;
        const double vl = l >= 0 ? v[l] : 0.0, vr = r >= 0 ? v[r] : 0.0;
        const double f = bond.stiffness(qr - ql) * (vr - vl);
        if (r >= 0) out[r] += f;
        if (l >= 0) out[l] -= f;
      };
      for (int b = chain_bonds_first(boundary); b < chain_bonds_end(boundary, n); ++b) {
        const auto s = chain_bond_sites(boundary, n, b);
        add_bond(s[0], s[1]);
      }
    });
    on_site.visit([&](const auto& u) {
      if constexpr (!std::decay_t<decltype(u)>::none)
        for (int i = 0; i < n; ++i) out[i] += u.stiffness(q[i]) * v[i];
    });
  }

 private:
  // The damp inside the fused 3s pass: p_i += (e^{-t a} - 1) p_i as ChainDamping::decay does it.
  static void decay_site(double e, double& p, int) { p += e * p; }
  static void decay_site(const double* e, double& p, int i) { p += e[i] * p; }

  template <class U>
  static double with_on_site(const U& u, double q, double bonded) {
    if constexpr (U::none) return bonded;
    else return bonded + u.force(q);
  }

  template <class Decay>
  void fused_3s(double* __restrict q, double* __restrict p, Decay e, double s1, double t, double s2) const {
    bonds.visit([&](const auto& bond) {
      on_site.visit([&](const auto& u) { fused_3s_pass(bond, u, q, p, e, s1, t, s2); });
    });
  }

  // Tile by tile (a tile's q, p and bond forces stay in L1): damp and drift the tile's sites
  // (q becomes q'); kick and drift again the sites whose neighbours are both q' by now, which
  // lag one site behind (the last site of a tile waits for the next tile's first). A site's
  // second drift overwrites its q', so the one the next tile's first kick needs is kept (lag),
  // as is q'_1 for site 0; sites 0 and n-1 (the boundary's bonds) are kicked last.
  template <class Bond, class U, class Decay>
  void fused_3s_pass(const Bond& bond, const U& u, double* __restrict q, double* __restrict p, Decay e, double s1,
                     double t, double s2) const {
    // 128 sites: measured at 10^6 sites (FPUT, -O3 x86-64), 1.05 ns/site with one coefficient or
    // one per site; 512 gave 1.3 ns/site with a coefficient per site (three streams a tile apart).
    constexpr int kTile = 128;
    std::array<double, kTile + 1> force;  // force[k]: V' of the bond from site lo + k - 1 to lo + k
    double q1 = 0.0, lag = 0.0;           // q'_1; q' of the last site kicked and drifted
    for (int a = 0; a < n; a += kTile) {
      const int b = std::min(a + kTile, n);
      for (int i = a; i < b; ++i) {
        decay_site(e, p[i], i);
        q[i] += s1 * p[i];
      }
      if (a == 0) q1 = q[1];
      const int lo = std::max(a - 1, 1), hi = b - 1;  // sites lo .. hi-1 now
      if (lo >= hi) continue;
      force[0] = bond.force(q[lo] - (a == 0 ? q[0] : lag));
      for (int i = lo + 1; i <= hi; ++i) force[i - lo] = bond.force(q[i] - q[i - 1]);
      lag = q[hi - 1];
      for (int i = lo; i < hi; ++i) {
        p[i] -= t * with_on_site(u, q[i], force[i - lo] - force[i - lo + 1]);
        q[i] += s2 * p[i];
      }
    }
    // Sites 0 and n-1 (q[0], q[n-1] still q'): their forces first, as the sweep computes them.
    const double first = left_end_force(bond, q), last = right_end_force(bond, q, first);
    const double g0 = with_on_site(u, q[0], first - bond.force(q1 - q[0]));
    const double g1 = with_on_site(u, q[n - 1], bond.force(q[n - 1] - (n == 2 ? q[0] : lag)) - last);
    p[0] -= t * g0;
    p[n - 1] -= t * g1;
    q[0] += s2 * p[0];
    q[n - 1] += s2 * p[n - 1];
  }

  // The bonds' forces at the two ends: the bond left of site 0 and right of site n-1
  // (a wall's, the periodic bond n-1 -> 0, or none).
  template <class Bond>
  double left_end_force(const Bond& bond, const double* q) const {
    if (boundary == ChainBoundary::fixed) return bond.force(q[0]);
    if (boundary == ChainBoundary::periodic) return bond.force(q[0] - q[n - 1]);
    return 0.0;
  }
  template <class Bond>
  double right_end_force(const Bond& bond, const double* q, double left_end) const {
    if (boundary == ChainBoundary::fixed) return bond.force(-q[n - 1]);
    if (boundary == ChainBoundary::periodic) return left_end;  // the same bond
    return 0.0;
  }

  template <class Bond, class Op>
  void sweep(const Bond& bond, const double* __restrict q, Op& op) const {
    const double first = left_end_force(bond, q);
    const double last = right_end_force(bond, q, first);
    if constexpr (Bond::polynomial) {
      // Each interior bond's force evaluated for both of its sites: no loop-carried
      // value, so the loop vectorises; the arithmetic is cheap beside the memory traffic.
      op(0, first - bond.force(q[1] - q[0]));
      for (int i = 1; i < n - 1; ++i) op(i, bond.force(q[i] - q[i - 1]) - bond.force(q[i + 1] - q[i]));
      op(n - 1, bond.force(q[n - 1] - q[n - 2]) - last);
    } else {
      double left = first;
      for (int i = 0; i < n - 1; ++i) {
        const double right = bond.force(q[i + 1] - q[i]);
        op(i, left - right);
        left = right;
      }
      op(n - 1, left - last);
    }
  }
};

}  // namespace raydamp
