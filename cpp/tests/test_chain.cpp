// The chain model (models/chain.hpp) against dense references:
// - every bond family's gradient is the central difference of its potential, its
//   Hessian product the difference of its gradient, on every boundary, with and
//   without each on-site potential;
// - the one-pass kick and drift equal p - t grad V and q + t p/m;
// - the block damping flows (disjoint dashpots, adjacent ones forming a tridiagonal
//   block, a dashpot on a wall bond, on-site friction) equal the dense constant-D
//   kind's exp(-tA) and t phi1(-tA) built from the same D to rounding;
// - bond dashpots conserve sum p; adjacent blocks past the cap are refused.
#include <cmath>
#include <cstdio>
#include <vector>

#include "check.hpp"
#include "raydamp/raydamp.hpp"

using namespace raydamp;
using Vec = Eigen::VectorXd;

namespace {

ChainBonds family(BondKind kind) {
  ChainBonds b;
  b.kind = kind;
  b.fput = {1.0, 0.25, 1.0};
  b.harmonic = {1.7};
  b.toda = {1.0, 0.8};
  b.morse = {0.9, 1.3};
  b.lennard_jones = {0.5, 1.0};
  return b;
}

Chain make_chain(int n, ChainBoundary boundary, BondKind kind, double eps, std::vector<int> bonds,
                 std::vector<int> sites) {
  std::vector<double> bc(bonds.size()), sc(sites.size());
  for (std::size_t i = 0; i < bc.size(); ++i) bc[i] = 0.3 + 0.1 * i;
  for (std::size_t i = 0; i < sc.size(); ++i) sc[i] = 0.2 + 0.05 * i;
  return Chain(n, boundary, family(kind), 1.5, eps, ChainDamping(boundary, n, 1.5, eps, bonds, bc, sites, sc),
               !sites.empty());
}

// D as a dense matrix, from the definition (bond gradients +-1, site unit vectors).
Eigen::MatrixXd dense_d(int n, ChainBoundary boundary, const std::vector<int>& bonds, const std::vector<int>& sites) {
  Eigen::MatrixXd d = Eigen::MatrixXd::Zero(n, n);
  for (std::size_t k = 0; k < bonds.size(); ++k) {
    Vec g = Vec::Zero(n);
    const auto s = chain_bond_sites(boundary, n, bonds[k]);
    if (s[0] >= 0) g[s[0]] -= 1.0;
    if (s[1] >= 0) g[s[1]] += 1.0;
    d += (0.3 + 0.1 * k) * g * g.transpose();
  }
  for (std::size_t k = 0; k < sites.size(); ++k) d(sites[k], sites[k]) += 0.2 + 0.05 * k;
  return d;
}

Vec wave(int n, double phase, double scale) {
  Vec v(n);
  for (int i = 0; i < n; ++i) v[i] = scale * std::sin(1.3 * i + phase);
  return v;
}

}  // namespace

int main() {
  const ChainBoundary boundaries[] = {ChainBoundary::fixed, ChainBoundary::periodic, ChainBoundary::free};
  const BondKind kinds[] = {BondKind::harmonic, BondKind::fput, BondKind::toda, BondKind::morse,
                            BondKind::lennard_jones};
  const int n = 7;
  ChainOnSite on_sites[3];
  on_sites[1].kind = OnSiteKind::polynomial;
  on_sites[1].polynomial = {0.7, 0.4};
  on_sites[2].kind = OnSiteKind::sine;
  on_sites[2].sine.g = 0.9;
  for (ChainBoundary boundary : boundaries)
    for (BondKind kind : kinds)
      for (const ChainOnSite& u : on_sites) {
      Chain c = make_chain(n, boundary, kind, 0.0, {}, {});
      c.on_site = u;
      const Vec q = wave(n, 0.2, 0.15), v = wave(n, 1.1, 1.0), p = wave(n, 2.0, 0.7);
      Vec g(n), hv(n);
      c.gradient(q, g);
      c.hessian_product(q, v, hv);
      const double step = 1e-6;
      for (int i = 0; i < n; ++i) {
        Vec a = q, b = q;
        a[i] += step;
        b[i] -= step;
        CHECK_NEAR(g[i], (c.potential(a) - c.potential(b)) / (2 * step), 1e-7);
      }
      Vec ga(n), gb(n);
      c.gradient(q + step * v, ga);
      c.gradient(q - step * v, gb);
      CHECK((hv - (ga - gb) / (2 * step)).norm() <= 1e-7);
      // One-pass kick and drift.
      Vec pk = p, qd = q;
      c.kick(q, pk, 0.3);
      CHECK((pk - (p - 0.3 * g)).norm() <= 1e-15);
      c.drift(qd, p, 0.3);
      CHECK((qd - (q + (0.3 / 1.5) * p)).norm() <= 1e-15);
      CHECK_NEAR(c.potential(Vec::Zero(n)), 0.0, 1e-15);
    }
  // An on-site potential ties sites to their rest positions: sum p is no longer conserved.
  {
    const Chain pinned(n, ChainBoundary::periodic, family(BondKind::fput), 1.5, 0.0,
                       ChainDamping(ChainBoundary::periodic, n, 1.5, 0.0, {}, {}, {}, {}), false, on_sites[2]);
    CHECK(pinned.momentum_count() == 0);
    CHECK(make_chain(n, ChainBoundary::periodic, BondKind::fput, 0.0, {}, {}).momentum_count() == 1);
  }

  // Damping blocks against the dense kind.
  struct Case {
    ChainBoundary boundary;
    std::vector<int> bonds, sites;
  };
  const int m = 12;
  const Case cases[] = {
      {ChainBoundary::fixed, {2, 6, 9}, {}},              // disjoint: 2x2 blocks
      {ChainBoundary::fixed, {0, 3, 4, 5, 12}, {}},       // wall bonds and a tridiagonal block
      {ChainBoundary::periodic, {0, 1, 11, 6}, {}},       // a block across the periodic seam
      {ChainBoundary::free, {1, 2, 7}, {2, 10}},          // bonds and on-site friction together
      {ChainBoundary::periodic, {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11}, {}},  // every bond
  };
  for (const Case& k : cases) {
    const double eps = 0.8, t = 0.37;
    const Chain c = make_chain(m, k.boundary, BondKind::fput, eps, k.bonds, k.sites);
    const ConstantDamping reference(1.5 * Eigen::MatrixXd::Identity(m, m), dense_d(m, k.boundary, k.bonds, k.sites),
                                    eps);
    const Vec q = wave(m, 0.1, 0.2), p = wave(m, 0.7, 1.0), g = wave(m, 1.9, 0.5);
    const auto f = c.damping.factors(t);
    const auto fr = reference.factors(t);
    Vec a = p, b = p;
    c.damping.decay(q, f, a);
    reference.decay(q, fr, b);
    CHECK((a - b).norm() <= 1e-14 * p.norm());
    a = p;
    b = p;
    c.damping.decay_affine(q, f, g, a);
    reference.decay_affine(q, fr, g, b);
    CHECK((a - b).norm() <= 1e-14 * p.norm());
    Vec ra(m), rb(m);
    c.damping.rate(q, p, ra);
    reference.rate(q, p, rb);
    CHECK((ra - rb).norm() <= 1e-14 * p.norm());
    CHECK_NEAR(c.dissipated_power(q, p), p.dot(rb) / 1.5, 1e-14);
    a = p;
    b = p;
    c.damping.solve_shifted(q, 0.4, a);
    reference.solve_shifted(q, 0.4, b);
    CHECK((a - b).norm() <= 1e-14 * p.norm());
    CHECK_NEAR(c.damping.spectral_radius(), reference.lambda.maxCoeff(), 1e-13);
    if (k.sites.empty() && k.boundary != ChainBoundary::fixed) {
      Vec d = p;
      c.damping.decay(q, f, d);
      CHECK_NEAR(d.sum(), p.sum(), 1e-14);
    }
  }
  // Bond dashpots on a periodic chain conserve sum p to rounding over many steps (the block
  // flows once drifted by 3e-11 in 2*10^4 steps: exp(-tA) = V diag V^T keeps column sums 1
  // only to a rounding that repeats every step; they now add a zero-sum correction).
  {
    const int np = 64;
    ChainBonds b = family(BondKind::toda);
    const std::vector<int> bonds{0, 1, 63, 20, 40};
    const Chain c(np, ChainBoundary::periodic, b, 1.0, 1.0,
                  ChainDamping(ChainBoundary::periodic, np, 1.0, 1.0, bonds, std::vector<double>(5, 0.5), {}, {}), false);
    State<Eigen::Dynamic> z{wave(np, 0.3, 0.5), wave(np, 1.2, 0.5) + Vec::Constant(np, 0.3)};
    for (const char* m : {"3s", "2s"}) {
      const MethodEntry& e = method_entry(m);
      const ButcherTableau& tab = resolve_tableau(e, "");
      const RunSpec spec{0.05, 20000, 0.05, 20000};
      const RunResult r = with_method(m, [&](auto mm) {
        return integrate<decltype(mm)>(c, tab, resolve_composition(e, tab, ""), z, spec);
      });
      CHECK(r.status == Status::completed);
      CHECK(r.max_momentum_drift < 1e-12);
      CHECK(r.trajectory.energy.back() < 0.5 * r.trajectory.energy.front());
    }
  }
  // Adjacent damped bonds past the block cap are refused, naming the dampers.
  std::vector<int> many;
  for (int b = 0; b <= kMaxChainBlock + 1; ++b) many.push_back(b);
  CHECK(test::throws([&] { make_chain(kMaxChainBlock + 10, ChainBoundary::fixed, BondKind::fput, 1.0, many, {}); }));
  CHECK(test::throws([&] { make_chain(10, ChainBoundary::free, BondKind::fput, 1.0, {0}, {}); }));  // no bond 0
  CHECK(test::throws([&] { make_chain(10, ChainBoundary::fixed, BondKind::fput, 1.0, {}, {10}); }));

  if (test::failures) std::printf("%d failures\n", test::failures);
  return test::failures ? 1 : 0;
}
