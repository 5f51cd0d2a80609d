// Butcher tableaux (a, b, c) as validated data. The order is computed from the
// order conditions, never typed in, so a wrong coefficient shows as a lower order.
#pragma once

#include <array>
#include <cmath>
#include <cstddef>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace raydamp {

enum class TableauKind { explicit_, diagonally_implicit, implicit };

class ButcherTableau {
 public:
  ButcherTableau(std::string name, std::vector<std::vector<double>> a, std::vector<double> b,
                 std::vector<double> c)
      : name_(std::move(name)), s_(static_cast<int>(b.size())), b_(std::move(b)), c_(std::move(c)) {
    // "tableau rk4: ..." for ours; "tableau: ..." for a user's table, which has no name yet.
    const std::string where = name_.empty() ? "tableau" : "tableau " + name_;
    if (s_ < 1) throw std::invalid_argument(where + ": b must have at least one weight");
    if (static_cast<int>(c_.size()) != s_ || static_cast<int>(a.size()) != s_)
      throw std::invalid_argument(where + ": a, b and c must all have s = len(b) rows");
    a_.assign(static_cast<std::size_t>(s_ * s_), 0.0);
    for (int i = 0; i < s_; ++i) {
      if (static_cast<int>(a[i].size()) != s_)
        throw std::invalid_argument(where + ": row " + std::to_string(i) + " of a must have s entries");
      long double row = 0.0L;
      for (int j = 0; j < s_; ++j) {
        a_[i * s_ + j] = a[i][j];
        row += a[i][j];
      }
      // Row sums equal c: the stages are then consistent at the times they claim.
      if (std::abs(row - c_[i]) > 1e-14L)
        throw std::invalid_argument(where + ": row " + std::to_string(i) + " of a does not sum to c[" +
                                    std::to_string(i) + "]");
    }
    kind_ = TableauKind::explicit_;
    for (int i = 0; i < s_; ++i)
      for (int j = i; j < s_; ++j)
        if (a_[i * s_ + j] != 0.0) {
          if (j > i) kind_ = TableauKind::implicit;
          else if (kind_ == TableauKind::explicit_) kind_ = TableauKind::diagonally_implicit;
        }
    order_ = computed_order();
    symmetric_ = computed_symmetry();
    if (order_ < 1) throw std::invalid_argument(where + ": weights b do not sum to 1 (not consistent)");
  }

  const std::string& name() const { return name_; }
  void rename(std::string name) { name_ = std::move(name); }
  int stages() const { return s_; }
  double a(int i, int j) const { return a_[i * s_ + j]; }
  double b(int i) const { return b_[i]; }
  double c(int i) const { return c_[i]; }
  TableauKind kind() const { return kind_; }
  bool is_explicit() const { return kind_ == TableauKind::explicit_; }
  int order() const { return order_; }
  // Symmetric (self-adjoint, Phi_{-h} = Phi_h^{-1}): the one-step maps a composition
  // may raise to higher order.
  bool is_symmetric() const { return symmetric_; }

 private:
  // b_i = b_{s+1-i} and a_ij + a_{s+1-i,s+1-j} = b_j (Hairer, Lubich & Wanner,
  // Geometric Numerical Integration, Theorem V.2.3).
  bool computed_symmetry() const {
    auto close = [](double x, double y) { return std::abs(x - y) < 1e-14; };
    for (int i = 0; i < s_; ++i) {
      if (!close(b_[i], b_[s_ - 1 - i])) return false;
      for (int j = 0; j < s_; ++j)
        if (!close(a(i, j) + a(s_ - 1 - i, s_ - 1 - j), b_[j])) return false;
    }
    return true;
  }

  // Checks the order conditions for trees up to order 4 in long double; returns
  // the highest order whose conditions all hold (up to 4, the highest we ship).
  int computed_order() const {
    using L = long double;
    const int s = s_;
    std::vector<L> ac(s, 0), ac2(s, 0), aac(s, 0);
    for (int i = 0; i < s; ++i)
      for (int j = 0; j < s; ++j) {
        ac[i] += a(i, j) * (L)c_[j];
        ac2[i] += a(i, j) * (L)c_[j] * c_[j];
      }
    for (int i = 0; i < s; ++i)
      for (int j = 0; j < s; ++j) aac[i] += a(i, j) * ac[j];
    auto sum = [&](auto term) {
      L total = 0;
      for (int i = 0; i < s; ++i) total += (L)b_[i] * term(i);
      return total;
    };
    auto holds = [](L value, L expected) { return std::abs(value - expected) < 1e-13L; };
    int order = 0;
    if (!holds(sum([](int) { return L(1); }), 1)) return order;
    order = 1;
    if (!holds(sum([&](int i) { return (L)c_[i]; }), L(1) / 2)) return order;
    order = 2;
    if (!holds(sum([&](int i) { return (L)c_[i] * c_[i]; }), L(1) / 3) ||
        !holds(sum([&](int i) { return ac[i]; }), L(1) / 6))
      return order;
    order = 3;
    if (!holds(sum([&](int i) { return (L)c_[i] * c_[i] * c_[i]; }), L(1) / 4) ||
        !holds(sum([&](int i) { return (L)c_[i] * ac[i]; }), L(1) / 8) ||
        !holds(sum([&](int i) { return ac2[i]; }), L(1) / 12) ||
        !holds(sum([&](int i) { return aac[i]; }), L(1) / 24))
      return order;
    return 4;
  }

  std::string name_;
  int s_;
  std::vector<double> a_;  // row-major s x s
  std::vector<double> b_, c_;
  TableauKind kind_;
  int order_;
  bool symmetric_;
};

// A validated tableau copied into fixed-size storage: the step loop instantiated
// with it has S known at compile time, so its stage loops unroll (the coefficients
// stay data, read from the tableau it was made from).
template <int S>
class FixedTableau {
 public:
  explicit FixedTableau(const ButcherTableau& tab) {
    if (tab.stages() != S) throw std::invalid_argument("FixedTableau: stage count mismatch");
    for (int i = 0; i < S; ++i) {
      b_[i] = tab.b(i);
      c_[i] = tab.c(i);
      for (int j = 0; j < S; ++j) a_[i * S + j] = tab.a(i, j);
    }
  }
  static constexpr int stages() { return S; }
  double a(int i, int j) const { return a_[i * S + j]; }
  double b(int i) const { return b_[i]; }
  double c(int i) const { return c_[i]; }

 private:
  std::array<double, S * S> a_{};
  std::array<double, S> b_{}, c_{};
};

// The tableaux raydamp ships, built and validated once.
inline const std::vector<ButcherTableau>& builtin_tableaux() {
  static const std::vector<ButcherTableau> tableaux{
      ButcherTableau("euler", {{0.0}}, {1.0}, {0.0}),
      // Heun's (Runge's) method, the paper's footnote in section 4.3.
      ButcherTableau("heun", {{0.0, 0.0}, {1.0, 0.0}}, {0.5, 0.5}, {0.0, 1.0}),
      // Implicit midpoint: one stage, a = 1/2. On the p-system (linear in p) it is one linear solve.
      ButcherTableau("midpoint", {{0.5}}, {1.0}, {0.5}),
      ButcherTableau("rk4", {{0, 0, 0, 0}, {0.5, 0, 0, 0}, {0, 0.5, 0, 0}, {0, 0, 1.0, 0}},
                     {1.0 / 6, 1.0 / 3, 1.0 / 3, 1.0 / 6}, {0, 0.5, 0.5, 1.0}),
  };
  return tableaux;
}

inline const ButcherTableau& builtin_tableau(const std::string& name) {
  for (const auto& t : builtin_tableaux())
    if (t.name() == name) return t;
  std::string known;
  for (const auto& t : builtin_tableaux()) known += (known.empty() ? "" : ", ") + t.name();
  throw std::invalid_argument("tableau: unknown tableau '" + name + "' (known: " + known + ")");
}

}  // namespace raydamp
