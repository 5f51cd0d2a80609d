// Dashpots on the bonds of a chain and friction on its sites, with M = m I:
//   D = sum_b c_b g_b g_b^T + sum_i c_i e_i e_i^T,
// g_b the gradient of bond b's stretch (+1 at its right site, -1 at its left; a
// wall contributes nothing). A stretch is linear in q, so D is constant and
// A = eps D / m is a constant symmetric PSD matrix whose nonzero entries sit on the
// damped sites only. Those sites split into blocks coupled by damping (connected
// components: a dashpot joins its two sites): disjoint dashpots are 2x2 blocks,
// adjacent damped bonds a tridiagonal block (a weighted path Laplacian), on-site
// friction a 1x1 block. Blocks commute, so exp(-tA) = prod over blocks of exp(-t A_k),
// each exact from the block's eigendecomposition (formed once here); undamped
// sites are left alone. Blocks are dense, so their size is capped (kMaxChainBlock).
//
// Thermal noise: with M = m I and A symmetric, the OU flow's covariance is
// kT (M - E M E^T) = kT m (I - e^{-2tA}), so a noise factor is sqrt(m) V diag(sqrt(1 - e^{-2t lambda})) V^T
// per block (a symmetric root: a block of dashpots alone, lambda = 0 along (1, ..., 1), gets noise that
// sums to zero, keeping sum p), and sqrt(m (1 - e^{-2ta})) per site of a diagonal A.
//
// When every block is a single site (friction, a lone wall dashpot), A is diagonal and
// exp(-tA) is a factor per site: the flows are then one loop over the damped sites, or
// over p itself when every site is damped (one factor per site, or one scalar when the
// coefficients agree), with no block bookkeeping. A 1x1 block's exp(-t a) - 1 is expm1(-t a)
// itself, so these loops compute the same numbers as the block path.
#pragma once

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <string>
#include <vector>

#include "raydamp/phi.hpp"

namespace raydamp {

inline constexpr int kMaxChainBlock = 256;  // sites in one block of adjacent dampers

// Where a chain's bond b sits: its left and right sites (-1 for a wall).
// fixed: bonds 0..n, bond b joins sites b-1 and b (bond 0 and bond n touch the walls);
// periodic: bonds 0..n-1, bond b joins sites b-1 and b with site -1 = site n-1;
// free: bonds 1..n-1, bond b joins sites b-1 and b.
enum class ChainBoundary { fixed, periodic, free };

inline int chain_bonds_first(ChainBoundary b) { return b == ChainBoundary::free ? 1 : 0; }
inline int chain_bonds_end(ChainBoundary b, int n) { return b == ChainBoundary::fixed ? n + 1 : n; }

inline std::array<int, 2> chain_bond_sites(ChainBoundary boundary, int n, int b) {
  int left = b - 1, right = b;
  if (boundary == ChainBoundary::periodic && left < 0) left = n - 1;
  if (boundary == ChainBoundary::fixed && right == n) right = -1;
  return {left, right};
}

class ChainDamping {
 public:
  // How A is laid out, which decides the flows' loops.
  enum class Shape {
    blocks,      // some block couples two or more sites: each block its own matrix
    sites,       // every block a single site, on some of the sites: A diagonal on those
    every_site,  // a single site per block on every site: A = diag(a_0, ..., a_{n-1})
    uniform,     // the same on every site: A = a I
  };
  struct Factors {
    double t = std::numeric_limits<double>::quiet_NaN();
    // Per block, s x s column-major: exp(-t A_k) - I and t (phi1(-t A_k) - I). The flows add
    // these corrections to the plain (undamped) update, so a block with a tiny t lambda
    // loses no digits, and a block whose dashpots conserve sum p (no wall, no site
    // friction) gets a correction with sum exactly zero (its mean removed): the flow then
    // conserves sum p to rounding instead of drifting by the rounding of V V^T each step.
    // A diagonal A: one value per damped site (one in all for Shape::uniform).
    std::vector<double> exp_m1, t_phi1_m1;
    // The noise factor over sqrt(m): sqrt(1 - e^{-2ta}) per damped site, or per block
    // V diag(sqrt(1 - e^{-2t lambda})) V^T (s x s, column-major, at the block's matrix offset).
    std::vector<double> noise;
    mutable std::vector<double> scratch;  // one value per damped site (kick+damp keeps results here)
  };

  ChainDamping() = default;

  // bonds/bond_c: damped bonds and their coefficients; sites/site_c: damped sites.
  template <int = 0>  // instantiated only where used: see raydamp.hpp
  ChainDamping(ChainBoundary boundary, int n, double mass, double eps, const std::vector<int>& bonds,
               const std::vector<double>& bond_c, const std::vector<int>& sites, const std::vector<double>& site_c) {
    if (bonds.size() != bond_c.size()) throw std::invalid_argument("dampers.c: one coefficient per bond");
    if (sites.size() != site_c.size()) throw std::invalid_argument("dampers.c: one coefficient per site");
    n_ = n;
    // Union-find over the sites a damper touches.
    std::vector<int> parent(n);
    std::iota(parent.begin(), parent.end(), 0);
    std::vector<char> touched(n, 0);
    auto root = [&](int i) {
      while (parent[i] != i) i = parent[i] = parent[parent[i]];
      return i;
    };
    const int first = chain_bonds_first(boundary), end = chain_bonds_end(boundary, n);
    const double scale = eps / mass;  // A = eps D M^{-1} with M = m I
    bool coupled = false;  // a damped bond joins two sites: some block has more than one
    for (std::size_t k = 0; k < bonds.size(); ++k) {
      const int b = bonds[k];
      if (b < first || b >= end)
        throw std::invalid_argument("dampers.bonds[" + std::to_string(k) + "]: bond " + std::to_string(b) +
                                    " is not a bond of this chain (bonds " + std::to_string(first) + ".." +
                                    std::to_string(end - 1) + ")");
      check_coefficient("dampers.c", k, bond_c[k]);
      // A damper with eps c = 0 does nothing: no block, so at eps = 0 the damping flows are
      // the identity exactly (not V V^T, which is I only to rounding).
      if (scale * bond_c[k] == 0.0) continue;
      const auto [l, r] = chain_bond_sites(boundary, n, b);
      if (l >= 0) touched[l] = 1;
      if (r >= 0) touched[r] = 1;
      if (l >= 0 && r >= 0) {
        parent[root(l)] = root(r);
        coupled = true;
      }
    }
    for (std::size_t k = 0; k < sites.size(); ++k) {
      if (sites[k] < 0 || sites[k] >= n)
        throw std::invalid_argument("dampers.sites[" + std::to_string(k) + "]: site " + std::to_string(sites[k]) +
                                    " is not a site of this chain (0.." + std::to_string(n - 1) + ")");
      check_coefficient("dampers.c", k, site_c[k]);
      if (scale * site_c[k] != 0.0) touched[sites[k]] = 1;
    }
    if (!coupled) {
      diagonal(boundary, n, scale, bonds, bond_c, sites, site_c, touched);
      return;
    }
    // Blocks in order of their first site; local index of each damped site.
    std::vector<int> block_of_root(n, -1), local(n, -1);
    std::vector<std::vector<int>> members;
    for (int i = 0; i < n; ++i) {
      if (!touched[i]) continue;
      int& k = block_of_root[root(i)];
      if (k < 0) {
        k = static_cast<int>(members.size());
        members.emplace_back();
      }
      local[i] = static_cast<int>(members[k].size());
      members[k].push_back(i);
    }
    std::vector<Eigen::MatrixXd> a(members.size());
    for (std::size_t k = 0; k < members.size(); ++k) {
      const int s = static_cast<int>(members[k].size());
      if (s > kMaxChainBlock)
        throw std::invalid_argument("dampers: " + std::to_string(s) + " adjacent sites (from site " +
                                    std::to_string(members[k].front()) + ") are coupled by damped bonds; the exact "
                                    "damping flow is formed for blocks of up to " + std::to_string(kMaxChainBlock) +
                                    " sites: damp fewer adjacent bonds, or use on-site friction (dampers.sites)");
      a[k] = Eigen::MatrixXd::Zero(s, s);
    }
    std::vector<char> leaks(members.size(), 0);  // a block with a wall bond or a damped site
    for (std::size_t k = 0; k < bonds.size(); ++k) {
      if (scale * bond_c[k] == 0.0) continue;
      const auto [l, r] = chain_bond_sites(boundary, n, bonds[k]);
      const double w = scale * bond_c[k];
      const int site = l >= 0 ? l : r;
      Eigen::MatrixXd& block = a[block_of_root[root(site)]];
      if (l >= 0) block(local[l], local[l]) += w;
      if (r >= 0) block(local[r], local[r]) += w;
      if (l >= 0 && r >= 0) {
        block(local[l], local[r]) -= w;
        block(local[r], local[l]) -= w;
      } else {
        leaks[block_of_root[root(site)]] = 1;  // a wall takes momentum
      }
    }
    for (std::size_t k = 0; k < sites.size(); ++k)
      if (scale * site_c[k] != 0.0) {
        a[block_of_root[root(sites[k])]](local[sites[k]], local[sites[k]]) += scale * site_c[k];
        leaks[block_of_root[root(sites[k])]] = 1;
      }

    for (std::size_t k = 0; k < members.size(); ++k) {
      const int s = static_cast<int>(members[k].size());
      Block block{s, static_cast<int>(sites_.size()), static_cast<int>(matrices_.size()), !leaks[k]};
      blocks_.push_back(block);
      sites_.insert(sites_.end(), members[k].begin(), members[k].end());
      Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(a[k]);
      if (eig.info() != Eigen::Success) throw std::invalid_argument("dampers: eigendecomposition failed");
      const Eigen::VectorXd lambda = eig.eigenvalues().cwiseMax(0.0);  // PSD: clip rounding
      lambda_.insert(lambda_.end(), lambda.data(), lambda.data() + s);
      vectors_.insert(vectors_.end(), eig.eigenvectors().data(), eig.eigenvectors().data() + s * s);
      matrices_.insert(matrices_.end(), a[k].data(), a[k].data() + s * s);
      rho_ = std::max(rho_, lambda.size() ? lambda.maxCoeff() : 0.0);
    }
  }

  Shape shape() const { return shape_; }
  int blocks() const {
    if (shape_ == Shape::blocks) return static_cast<int>(blocks_.size());
    return shape_ == Shape::sites ? static_cast<int>(sites_.size()) : n_;
  }
  int largest_block() const {
    if (shape_ != Shape::blocks) return blocks() > 0 ? 1 : 0;
    int s = 0;
    for (const Block& b : blocks_) s = std::max(s, b.size);
    return s;
  }
  // The largest eigenvalue of A: known exactly, no power iteration (amplification guard).
  double spectral_radius() const { return rho_; }

  Factors factors(double t) const {
    Factors f;
    f.t = t;
    if (shape_ != Shape::blocks) {
      // A 1x1 block's V V^T (decay - 1) is decay - 1 itself: the same values as below.
      const std::size_t m = rates_.size();
      f.exp_m1.resize(m);
      f.t_phi1_m1.resize(m);
      f.noise.resize(m);
      if (shape_ == Shape::sites) f.scratch.resize(m);
      for (std::size_t k = 0; k < m; ++k) {
        if (k > 0 && rates_[k] == rates_[k - 1]) {  // runs of one coefficient: no exp to recompute
          f.exp_m1[k] = f.exp_m1[k - 1];
          f.t_phi1_m1[k] = f.t_phi1_m1[k - 1];
          f.noise[k] = f.noise[k - 1];
          continue;
        }
        const double x = -t * rates_[k];
        f.exp_m1[k] = std::expm1(x);
        f.t_phi1_m1[k] = t * (phi1(x) - 1.0);
        f.noise[k] = std::sqrt(std::max(0.0, -std::expm1(2.0 * x)));
      }
      return f;
    }
    f.exp_m1.resize(matrices_.size());
    f.t_phi1_m1.resize(matrices_.size());
    f.noise.resize(matrices_.size());
    f.scratch.resize(sites_.size());
    for (const Block& b : blocks_) {
      const int s = b.size;
      const double* v = &vectors_[b.matrix];
      std::array<double, kMaxChainBlock> decay, t_phi1s, roots;
      for (int m = 0; m < s; ++m) {
        const double x = -t * lambda_[b.site + m];
        decay[m] = std::expm1(x);
        t_phi1s[m] = t * (phi1(x) - 1.0);
        roots[m] = std::sqrt(std::max(0.0, -std::expm1(2.0 * x)));
      }
      for (int j = 0; j < s; ++j)
        for (int i = 0; i < s; ++i) {
          double e = 0.0, p1 = 0.0, r = 0.0;
          for (int m = 0; m < s; ++m) {
            const double vv = v[i + m * s] * v[j + m * s];
            e += vv * decay[m];
            p1 += vv * t_phi1s[m];
            r += vv * roots[m];
          }
          f.exp_m1[b.matrix + i + j * s] = e;
          f.t_phi1_m1[b.matrix + i + j * s] = p1;
          f.noise[b.matrix + i + j * s] = r;
        }
    }
    return f;
  }

  // p <- exp(-tA) p = p + (exp(-tA) - I) p on every block; the undamped sites keep their p.
  template <class Q, class P>
  void decay(const Q&, const Factors& f, P& p) const {
    double* __restrict x = p.data();
    const double* __restrict e = f.exp_m1.data();
    switch (shape_) {
      case Shape::uniform: {
        const double e0 = e[0];
        for (int i = 0; i < n_; ++i) x[i] += e0 * x[i];
        return;
      }
      case Shape::every_site:
        for (int i = 0; i < n_; ++i) x[i] += e[i] * x[i];
        return;
      case Shape::sites:
        for (std::size_t k = 0; k < sites_.size(); ++k) x[sites_[k]] += e[k] * x[sites_[k]];
        return;
      case Shape::blocks:
        break;
    }
    for (const Block& b : blocks_) {  // a lone dashpot's 2x2 block unrolled: the same operations
      if (b.size == 2) decay_block<2>(b, &f.exp_m1[b.matrix], p);
      else decay_block<0>(b, &f.exp_m1[b.matrix], p);
    }
  }

  // p += sigma sqrt(m) N xi: the noise of the exact OU flow (header comment); the undamped sites get none.
  template <class Q, class Mass, class X, class P>
  void add_noise(const Q&, const Factors& f, const Mass& mass, double sigma, const X& xi, P& p) const {
    const double c = sigma * std::sqrt(mass.m);
    const double* r = f.noise.data();
    switch (shape_) {
      case Shape::uniform:
        p += (c * r[0]) * xi;
        return;
      case Shape::every_site:
        for (int i = 0; i < n_; ++i) p[i] += c * r[i] * xi[i];
        return;
      case Shape::sites:
        for (std::size_t k = 0; k < sites_.size(); ++k) p[sites_[k]] += c * r[k] * xi[sites_[k]];
        return;
      case Shape::blocks:
        break;
    }
    std::array<double, kMaxChainBlock> y;
    for (const Block& b : blocks_) {
      const int s = b.size;
      const double* root = &f.noise[b.matrix];
      for (int i = 0; i < s; ++i) {
        double sum = 0.0;
        for (int j = 0; j < s; ++j) sum += root[i + j * s] * xi[sites_[b.site + j]];
        y[i] = sum;
      }
      if (b.conserving) remove_mean(s, y.data());  // the exact noise sums to zero there: keep sum p to rounding
      for (int i = 0; i < s; ++i) p[sites_[b.site + i]] += c * y[i];
    }
  }

  // p <- exp(-tA) p - t phi1(-tA) g: the blocks first (into scratch, from the old p),
  // then the plain kick p - t g everywhere, then the blocks' values back.
  template <class Q, class G, class P>
  void decay_affine(const Q&, const Factors& f, const G& g, P& p) const {
    // As (p - t g) + [(exp(-tA) - I) p - t (phi1(-tA) - I) g]: the plain kick plus a correction.
    if (shape_ != Shape::blocks) {
      double* __restrict x = p.data();
      const double* __restrict y = g.data();
      const double* __restrict e = f.exp_m1.data();
      const double* __restrict tp = f.t_phi1_m1.data();
      const double t = f.t;
      if (shape_ == Shape::uniform) {
        for (int i = 0; i < n_; ++i) x[i] = affine_decay(e[0], tp[0], t, x[i], y[i]);
      } else if (shape_ == Shape::every_site) {
        for (int i = 0; i < n_; ++i) x[i] = affine_decay(e[i], tp[i], t, x[i], y[i]);
      } else {
        for (std::size_t k = 0; k < sites_.size(); ++k) f.scratch[k] = affine_decay(e[k], tp[k], t, x[sites_[k]], y[sites_[k]]);
        p -= t * g;
        for (std::size_t k = 0; k < sites_.size(); ++k) x[sites_[k]] = f.scratch[k];
      }
      return;
    }
    for (const Block& b : blocks_) {
      if (b.size == 2) affine_block<2>(b, f, g, p);
      else affine_block<0>(b, f, g, p);
    }
    p -= f.t * g;
    for (const Block& b : blocks_) scatter(b, &f.scratch[b.site], p);
  }

  // out = A p.
  template <class Q, class P, class O>
  void rate(const Q&, const P& p, O& out) const {
    if (shape_ == Shape::uniform) {
      out.noalias() = rates_[0] * p;
      return;
    }
    if (shape_ == Shape::every_site) {
      out.noalias() = rates().cwiseProduct(p);
      return;
    }
    out.setZero(p.size());
    if (shape_ == Shape::sites) {
      for (std::size_t k = 0; k < sites_.size(); ++k) out[sites_[k]] = rates_[k] * p[sites_[k]];
      return;
    }
    std::array<double, kMaxChainBlock> y;
    for (const Block& b : blocks_) {
      multiply(b, &matrices_[b.matrix], p, y.data());
      scatter(b, y.data(), out);
    }
  }

  // p^T A p / m = v . A p: the dissipated power, from the damped sites alone.
  template <class P>
  double power(const P& p, double inverse_mass) const {
    // Every site: one vectorised reduction (its sum in another order than the blocks': equal to rounding).
    if (shape_ == Shape::uniform) return inverse_mass * (rates_[0] * p.squaredNorm());
    if (shape_ == Shape::every_site) return inverse_mass * rates().dot(p.cwiseAbs2());
    double sum = 0.0;
    if (shape_ == Shape::sites) {
      for (std::size_t k = 0; k < sites_.size(); ++k) sum += p[sites_[k]] * (rates_[k] * p[sites_[k]]);
      return inverse_mass * sum;
    }
    std::array<double, kMaxChainBlock> y;
    for (const Block& b : blocks_) {
      multiply(b, &matrices_[b.matrix], p, y.data());
      for (int i = 0; i < b.size; ++i) sum += p[sites_[b.site + i]] * y[i];
    }
    return inverse_mass * sum;
  }

  // x <- (I + c A)^{-1} x = V diag(1 / (1 + c lambda)) V^T x on each block.
  template <class Q, class X>
  void solve_shifted(const Q&, double c, X& x) const {
    switch (shape_) {
      case Shape::uniform:
        x /= 1.0 + c * rates_[0];
        return;
      case Shape::every_site:
        for (int i = 0; i < n_; ++i) x[i] /= 1.0 + c * rates_[i];
        return;
      case Shape::sites:
        for (std::size_t k = 0; k < sites_.size(); ++k) x[sites_[k]] /= 1.0 + c * rates_[k];
        return;
      case Shape::blocks:
        break;
    }
    std::array<double, kMaxChainBlock> y, z;
    for (const Block& b : blocks_) {
      const int s = b.size;
      const double* v = &vectors_[b.matrix];
      for (int m = 0; m < s; ++m) {
        double sum = 0.0;
        for (int i = 0; i < s; ++i) sum += v[i + m * s] * x[sites_[b.site + i]];
        y[m] = sum / (1.0 + c * lambda_[b.site + m]);
      }
      for (int i = 0; i < s; ++i) {
        double sum = 0.0;
        for (int m = 0; m < s; ++m) sum += v[i + m * s] * y[m];
        z[i] = sum;
      }
      scatter(b, z.data(), x);
    }
  }

  // The diagonal of A per damped site (Shape::sites: at damped_sites(); every_site: at every
  // site; uniform: one value for all).
  Eigen::Map<const Eigen::VectorXd> rates() const {
    return {rates_.data(), static_cast<Eigen::Index>(rates_.size())};
  }
  const std::vector<int>& damped_sites() const { return sites_; }

  // One site of the exact kick+damp flow with A = a: e^{-ta} p - t phi1(-ta) g, as the plain kick
  // p - t g plus its correction (e = e^{-ta} - 1, tp = t (phi1(-ta) - 1)), as the block path sums them.
  static double affine_decay(double e, double tp, double t, double p, double g) {
    return (e * p - tp * g) + (p - t * g);
  }

 private:
  // Every block a single site: the diagonal of A, summed in the block path's order (bonds, then sites).
  void diagonal(ChainBoundary boundary, int n, double scale, const std::vector<int>& bonds,
                const std::vector<double>& bond_c, const std::vector<int>& sites, const std::vector<double>& site_c,
                const std::vector<char>& touched) {
    n_ = n;
    std::vector<double> a(n, 0.0);
    for (std::size_t k = 0; k < bonds.size(); ++k) {
      if (scale * bond_c[k] == 0.0) continue;
      for (const int i : chain_bond_sites(boundary, n, bonds[k]))
        if (i >= 0) a[i] += scale * bond_c[k];
    }
    for (std::size_t k = 0; k < sites.size(); ++k)
      if (scale * site_c[k] != 0.0) a[sites[k]] += scale * site_c[k];
    for (int i = 0; i < n; ++i)
      if (touched[i]) {
        sites_.push_back(i);
        rates_.push_back(a[i]);
        rho_ = std::max(rho_, a[i]);
      }
    shape_ = Shape::sites;
    if (static_cast<int>(sites_.size()) == n) {
      shape_ = std::all_of(rates_.begin(), rates_.end(), [&](double r) { return r == rates_[0]; })
                   ? Shape::uniform
                   : Shape::every_site;
      sites_.clear();
      sites_.shrink_to_fit();
      if (shape_ == Shape::uniform) rates_.resize(1);
    }
  }

  struct Block {
    int size;         // sites in the block
    int site;         // offset into sites_ and lambda_
    int matrix;       // offset into vectors_, matrices_ and the factors' blocks
    bool conserving;  // only dashpots between its own sites: A_k annihilates (1, ..., 1)
  };

  // p += (exp(-t A_k) - I) p on block b; S: its size where known at compile time, else 0.
  template <int S, class P>
  void decay_block(const Block& b, const double* m, P& p) const {
    const int s = S > 0 ? S : b.size;
    std::array<double, (S > 0 ? S : kMaxChainBlock)> d;
    multiply<S>(b, m, p, d.data());
    if (b.conserving) remove_mean<S>(s, d.data());
    for (int i = 0; i < s; ++i) p[sites_[b.site + i]] += d[i];
  }

  // Block b's values of exp(-t A_k) p - t phi1(-t A_k) g, into the factors' scratch.
  template <int S, class G, class P>
  void affine_block(const Block& b, const Factors& f, const G& g, const P& p) const {
    const int s = S > 0 ? S : b.size;
    double* y = &f.scratch[b.site];
    multiply<S>(b, &f.exp_m1[b.matrix], p, y);
    const double* tp = &f.t_phi1_m1[b.matrix];
    for (int j = 0; j < s; ++j) {
      const double gj = g[sites_[b.site + j]];
      for (int i = 0; i < s; ++i) y[i] -= tp[i + j * s] * gj;
    }
    if (b.conserving) remove_mean<S>(s, y);
    for (int i = 0; i < s; ++i) {
      const int k = sites_[b.site + i];
      y[i] += p[k] - f.t * g[k];
    }
  }

  template <int S = 0>
  static void remove_mean(int size, double* d) {
    const int s = S > 0 ? S : size;
    double sum = 0.0;
    for (int i = 0; i < s; ++i) sum += d[i];
    const double mean = sum / s;
    for (int i = 0; i < s; ++i) d[i] -= mean;
  }

  static void check_coefficient(const char* argument, std::size_t k, double c) {
    if (!(std::isfinite(c) && c >= 0.0))
      throw std::invalid_argument(std::string(argument) + "[" + std::to_string(k) +
                                  "] must be a finite number >= 0, got " + std::to_string(c));
  }

  // y = B p restricted to the block (B s x s column-major).
  template <int S = 0, class P>
  void multiply(const Block& b, const double* m, const P& p, double* y) const {
    const int s = S > 0 ? S : b.size;
    for (int i = 0; i < s; ++i) y[i] = 0.0;
    for (int j = 0; j < s; ++j) {
      const double pj = p[sites_[b.site + j]];
      for (int i = 0; i < s; ++i) y[i] += m[i + j * s] * pj;
    }
  }

  template <class P>
  void scatter(const Block& b, const double* y, P& p) const {
    for (int i = 0; i < b.size; ++i) p[sites_[b.site + i]] = y[i];
  }

  std::vector<Block> blocks_;
  std::vector<int> sites_;          // the damped sites, block by block
  std::vector<double> lambda_;      // eigenvalues of each block's A_k
  std::vector<double> vectors_;     // its eigenvectors (column-major s x s)
  std::vector<double> matrices_;    // A_k itself
  std::vector<double> rates_;       // a diagonal A: its entries (Shape::sites, every_site, uniform)
  Shape shape_ = Shape::blocks;
  int n_ = 0;                       // sites of the chain
  double rho_ = 0.0;
};

}  // namespace raydamp
