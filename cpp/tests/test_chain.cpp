// The chain model (models/chain.hpp) against dense references:
// - every bond family's gradient is the central difference of its potential, its
//   Hessian product the difference of its gradient, on every boundary, with and
//   without each on-site potential;
// - the one-pass kick and drift equal p - t grad V and q + t p/m;
// - the block damping flows (disjoint dashpots, adjacent ones forming a tridiagonal
//   block, a dashpot on a wall bond, on-site friction) equal the dense constant-D
//   kind's exp(-tA) and t phi1(-tA) built from the same D to rounding;
// - friction alone (A diagonal: on some sites, on every site with a coefficient each, on
//   every site with one coefficient; a lone wall dashpot) takes the per-site loops, checked
//   against the same dense reference and against e^{-t a} p itself;
// - the fused 3s pass (join then body in one pass) and the one-pass kick+damp equal the
//   sub-flows one after another bit for bit, for every shape of damping, family, boundary,
//   on-site potential, and for n across the pass's tiles;
// - uniform friction on a periodic chain: 3s and 2s take sum p down as e^{-eps c t / m};
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
      // A diagonal: friction on some sites, lone wall dashpots with friction, friction everywhere.
      {ChainBoundary::fixed, {}, {1, 4, 5, 9}},
      {ChainBoundary::fixed, {0, 12}, {3, 11}},
      {ChainBoundary::periodic, {}, {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11}},
      {ChainBoundary::free, {}, {11, 10, 9, 8, 7, 6, 5, 4, 3, 2, 1, 0}},
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
  // Shapes: friction alone is diagonal; every site with one coefficient is A = a I.
  {
    CHECK(make_chain(m, ChainBoundary::fixed, BondKind::fput, 0.8, {}, {1, 4}).damping.shape() ==
          ChainDamping::Shape::sites);
    CHECK(make_chain(m, ChainBoundary::fixed, BondKind::fput, 0.8, {0, 12}, {}).damping.shape() ==
          ChainDamping::Shape::sites);
    CHECK(make_chain(m, ChainBoundary::fixed, BondKind::fput, 0.8, {2}, {4}).damping.shape() ==
          ChainDamping::Shape::blocks);
    std::vector<int> all(m);
    for (int i = 0; i < m; ++i) all[i] = i;
    const Chain each = make_chain(m, ChainBoundary::fixed, BondKind::fput, 0.8, {}, all);
    CHECK(each.damping.shape() == ChainDamping::Shape::every_site);
    CHECK(each.damping.blocks() == m && each.damping.largest_block() == 1);
    const ChainDamping one(ChainBoundary::fixed, m, 1.5, 0.8, {}, {}, all, std::vector<double>(m, 0.3));
    CHECK(one.shape() == ChainDamping::Shape::uniform);
    CHECK(one.blocks() == m && one.largest_block() == 1);
    CHECK_NEAR(one.spectral_radius(), 0.8 * 0.3 / 1.5, 1e-16);
    // Against e^{-t a} p and e^{-t a} p - t phi1(-t a) g themselves (a wrong factor fails here).
    const double t = 0.37;
    const Vec q = wave(m, 0.1, 0.2), p = wave(m, 0.7, 1.0), g = wave(m, 1.9, 0.5);
    for (const ChainDamping* d : {&each.damping, &one}) {
      const auto f = d->factors(t);
      Vec a = p, b = p;
      d->decay(q, f, a);
      d->decay_affine(q, f, g, b);
      Eigen::MatrixXd dd = Eigen::MatrixXd::Zero(m, m);  // D
      for (int i = 0; i < m; ++i) {
        dd(i, i) = d == &one ? 0.3 : 0.2 + 0.05 * i;
        const double rate = 0.8 * dd(i, i) / 1.5;
        CHECK_NEAR(a[i], std::exp(-t * rate) * p[i], 1e-15);
        CHECK_NEAR(b[i], std::exp(-t * rate) * p[i] - (1.0 - std::exp(-t * rate)) / rate * g[i], 1e-15);
      }
      const ConstantDamping reference(1.5 * Eigen::MatrixXd::Identity(m, m), dd, 0.8);
      Vec ra(m), rb(m);
      d->rate(q, p, ra);
      reference.rate(q, p, rb);
      CHECK((ra - rb).norm() <= 1e-15 * p.norm());
      CHECK_NEAR(d->power(p, 1.0 / 1.5), p.dot(rb) / 1.5, 1e-14);
      a = p;
      b = p;
      d->solve_shifted(q, 0.4, a);
      reference.solve_shifted(q, 0.4, b);
      CHECK((a - b).norm() <= 1e-15 * p.norm());
    }
  }
  // The fused 3s pass and the one-pass kick+damp against the sub-flows in turn, bit for bit:
  // every shape of damping, family, boundary and on-site potential, n across the pass's tiles.
  {
    const double t[3] = {0.021, 0.043, 0.022}, join = 0.044;
    for (const int nn : {2, 3, 4, 127, 128, 129, 130, 257, 1100}) {
      std::vector<int> all(nn), some, pairs, odd_bonds;
      for (int i = 0; i < nn; ++i) all[i] = i;
      for (int i = 1; i < nn; i += 3) some.push_back(i);
      for (int b = 1; b < nn; b += 2) pairs.push_back(b);
      std::vector<std::vector<double>> site_c = {std::vector<double>(nn, 0.3), {}};
      for (int i = 0; i < nn; ++i) site_c[1].push_back(0.1 + 0.01 * (i % 7));
      for (ChainBoundary boundary : boundaries) {
        const std::vector<ChainDamping> dampings = {
            ChainDamping(boundary, nn, 1.5, 0.9, {}, {}, {}, {}),                                   // none
            ChainDamping(boundary, nn, 1.5, 0.9, {}, {}, all, site_c[0]),                           // uniform
            ChainDamping(boundary, nn, 1.5, 0.9, {}, {}, all, site_c[1]),                           // every site
            ChainDamping(boundary, nn, 1.5, 0.9, {}, {}, some, std::vector<double>(some.size(), 0.2)),  // sites
            ChainDamping(boundary, nn, 1.5, 0.9, pairs, std::vector<double>(pairs.size(), 0.2), {}, {}),  // blocks
        };
        for (BondKind kind : kinds)
          for (const ChainOnSite& u : on_sites)
            for (const ChainDamping& d : dampings) {
              const Chain c(nn, boundary, family(kind), 1.5, 0.9, d, false, u);
              const Vec q = wave(nn, 0.4, 0.15), p = wave(nn, 1.7, 0.6);
              const auto f = c.damping.factors(join);
              Vec qa = q, pa = p, qb = q, pb = p;
              c.damp_then_3s_body(qa, pa, f, t);
              c.damping.decay(qb, f, pb);
              c.drift(qb, pb, t[0]);
              c.kick(qb, pb, t[1]);
              c.drift(qb, pb, t[2]);
              CHECK(qa == qb && pa == pb);
              pa = p;
              pb = p;
              Vec g(nn), g2(nn);
              c.kick_damp(q, pa, f, g);
              c.gradient(q, g2);
              c.damping.decay_affine(q, f, g2, pb);
              CHECK(pa == pb);
            }
      }
    }
  }
  // Uniform friction on a periodic chain: the bond forces sum to zero, so sum p decays as
  // e^{-eps c t / m} exactly; 3s (its fused pass between steps) and 2s (one-pass kick+damp)
  // follow it to rounding.
  {
    const int np = 600;  // several tiles of the fused pass and a partial one
    std::vector<int> all(np);
    for (int i = 0; i < np; ++i) all[i] = i;
    const double eps = 0.7, c0 = 0.3, mass = 1.5;
    const Chain c(np, ChainBoundary::periodic, family(BondKind::fput), mass, eps,
                  ChainDamping(ChainBoundary::periodic, np, mass, eps, {}, {}, all, std::vector<double>(np, c0)), true);
    State<Eigen::Dynamic> z{wave(np, 0.3, 0.5), wave(np, 1.2, 0.5) + Vec::Constant(np, 0.3)};
    for (const char* m : {"3s", "2s"}) {
      const MethodEntry& e = method_entry(m);
      const ButcherTableau& tab = resolve_tableau(e, "");
      const RunSpec spec{0.05, 2000, 0.05, 500};
      const RunResult r = with_method(m, [&](auto mm) {
        return integrate<decltype(mm)>(c, tab, resolve_composition(e, tab, ""), z, spec);
      });
      CHECK(r.status == Status::completed);
      const int rows = static_cast<int>(r.trajectory.t.size());
      for (int k = 0; k < rows; ++k) {
        double sum = 0.0;
        for (int i = 0; i < np; ++i) sum += r.trajectory.p[static_cast<std::size_t>(k) * np + i];
        const double expected = z.p.sum() * std::exp(-eps * c0 / mass * r.trajectory.t[k]);
        CHECK_NEAR(sum, expected, 1e-12 * np);
      }
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
