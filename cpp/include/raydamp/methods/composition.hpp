// Compositions as data: Psi_h = Phi_{gamma_m h} o ... o Phi_{gamma_1 h} of a
// symmetric order-2 step Phi (paper section 7: "an easy extension to construct
// higher order methods by using higher order compositions"). A composition is
// its coefficients gamma_i, nothing else: the step loop runs any of them over
// any symmetric base table.
//
// Every table is symmetric and has an odd number of stages. It is built from its
// outer coefficients as printed in the paper that introduced it; the middle one
// is derived from sum gamma_i = 1 and the mirrored half is never typed. The
// constants are computed in long double and checked when built: sum = 1,
// palindrome, and the odd-power conditions sum gamma_i^k = 0 (k = 3, 5, ... < order)
// that every symmetric composition of order `order` satisfies (the one-stage
// trees of Hairer, Lubich & Wanner, Geometric Numerical Integration, V.3.2), so
// a mistyped digit is refused rather than run at a lower order.
#pragma once

#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "raydamp/methods/near_integrable.hpp"

namespace raydamp {

// Stages a composition may have (kahan_li8 has 17): the step loop keeps a composed
// step's durations in fixed storage of this size.
inline constexpr int kMaxCompositionStages = 32;

class Composition {
 public:
  // outer: gamma_1 ... gamma_k of a palindrome with 2k + 1 stages; gamma_{k+1}
  // (the middle) is 1 - 2 (gamma_1 + ... + gamma_k).
  Composition(std::string name, int order, std::vector<long double> outer, std::string reference)
      : name_(std::move(name)), order_(order), reference_(std::move(reference)) {
    long double outer_sum = 0.0L;
    for (long double g : outer) outer_sum += g;
    std::vector<long double> full(outer);
    full.push_back(1.0L - 2.0L * outer_sum);
    full.insert(full.end(), outer.rbegin(), outer.rend());
    if (static_cast<int>(full.size()) > kMaxCompositionStages)
      throw std::invalid_argument("composition " + name_ + ": more than " + std::to_string(kMaxCompositionStages) +
                                  " stages");
    validate(full);
    for (long double g : full) gammas_.push_back(static_cast<double>(g));
  }

  // A near-integrable table (methods/near_integrable.hpp) over a base X(1/2) Y(1) X(1/2): the step
  // X(a_0 h) Y(b_1 h) X(a_1 h) ... Y(b_n h) X(a_n h), its error O(eps h^{eps_order} + eps^2 h^2) where the base's
  // Y carries the small part eps B of H = A + eps B and X is A's exact flow. Its order() is 2, what it
  // guarantees on any system; gammas() are its middle fractions b_i (so stages() counts its kicks).
  Composition(std::string name, int eps_order, near_integrable::Table table, std::string reference)
      : name_(std::move(name)), order_(2), eps_order_(eps_order), reference_(std::move(reference)) {
    if (static_cast<int>(table.middles.size()) > kMaxCompositionStages)
      throw std::invalid_argument("composition " + name_ + ": more than " + std::to_string(kMaxCompositionStages) +
                                  " stages");
    validate_table(table);
    for (long double b : table.middles) gammas_.push_back(static_cast<double>(b));
    for (long double a : table.ends) ends_.push_back(static_cast<double>(a));
  }

  const std::string& name() const { return name_; }
  int order() const { return order_; }
  // Whether this is a near-integrable table (its sub-flow fractions are ends() and gammas()), and the power
  // of h in its error's eps term; a composition's own order otherwise.
  bool is_table() const { return !ends_.empty(); }
  int eps_order() const { return is_table() ? eps_order_ : order_; }
  const std::vector<double>& ends() const { return ends_; }
  const std::string& reference() const { return reference_; }
  int stages() const { return static_cast<int>(gammas_.size()); }
  const std::vector<double>& gammas() const { return gammas_; }
  double gamma(int i) const { return gammas_[i]; }
  double min_gamma() const {
    double m = gammas_[0];
    for (double g : gammas_) m = std::min(m, g);
    return m;
  }

 private:
  void validate(const std::vector<long double>& g) const {
    const std::size_t m = g.size();
    long double sum = 0.0L;
    for (long double x : g) sum += x;
    // The constants are printed to 20-26 digits; long double keeps about 19.
    constexpr long double tolerance = 1e-16L;
    if (std::abs(sum - 1.0L) > tolerance)
      throw std::invalid_argument("composition " + name_ + ": coefficients do not sum to 1");
    for (std::size_t i = 0; i < m; ++i)
      if (g[i] != g[m - 1 - i]) throw std::invalid_argument("composition " + name_ + ": not a palindrome");
    for (int k = 3; k < order_; k += 2) {
      long double moment = 0.0L;
      for (long double x : g) moment += std::pow(x, k);
      if (std::abs(moment) > tolerance)
        throw std::invalid_argument("composition " + name_ + ": sum gamma^" + std::to_string(k) +
                                    " is not 0, so the order cannot be " + std::to_string(order_));
    }
  }

  // Fractions >= 0 summing to 1, palindromes, and kicks that integrate 1, tau, ..., tau^{eps_order - 1} over
  // [0, 1] exactly: a mistyped or mis-computed entry is refused.
  void validate_table(const near_integrable::Table& t) const {
    const std::string where = "composition " + name_ + ": ";
    if (t.middles.empty() || t.ends.size() != t.middles.size() + 1)
      throw std::invalid_argument(where + "a table has one more end fraction than middle ones");
    constexpr long double tolerance = 1e-16L;
    for (const auto* v : {&t.ends, &t.middles}) {
      long double sum = 0.0L;
      const std::size_t m = v->size();
      for (std::size_t i = 0; i < m; ++i) {
        if (!((*v)[i] >= 0.0L)) throw std::invalid_argument(where + "a negative fraction");
        if ((*v)[i] != (*v)[m - 1 - i]) throw std::invalid_argument(where + "not a palindrome");
        sum += (*v)[i];
      }
      if (std::abs(sum - 1.0L) > tolerance) throw std::invalid_argument(where + "fractions do not sum to 1");
    }
    for (int k = 0; k < eps_order_; ++k) {
      long double tau = 0.0L, moment = 0.0L;
      for (std::size_t i = 0; i < t.middles.size(); ++i) {
        tau += t.ends[i];
        moment += t.middles[i] * std::pow(tau, k);
      }
      if (std::abs(moment - 1.0L / (k + 1)) > tolerance)
        throw std::invalid_argument(where + "its kicks do not integrate tau^" + std::to_string(k) +
                                    " exactly, so the eps-order cannot be " + std::to_string(eps_order_));
    }
  }

  std::string name_;
  int order_;
  int eps_order_ = 0;
  std::vector<double> ends_;
  std::string reference_;
  std::vector<double> gammas_;
};

// The compositions raydamp ships, built and validated once. "none" is the base
// step itself (one stage, gamma = 1).
inline const std::vector<Composition>& builtin_compositions() {
  static const std::vector<Composition> compositions = [] {
    std::vector<Composition> c;
    c.emplace_back("none", 2, std::vector<long double>{}, "the symmetric base step alone");
    // Triple jump: gamma_1 = 1 / (2 - 2^{1/3}); the middle -2^{1/3} gamma_1 follows from the sum.
    const long double cbrt2 = std::cbrt(2.0L), cbrt4 = std::cbrt(4.0L);
    c.emplace_back("yoshida4", 4, std::vector<long double>{1.0L / (2.0L - cbrt2)},
                   "Yoshida, Phys. Lett. A 150 (1990) 262: the triple jump");
    // Suzuki's fractal: four stages of 1 / (4 - 4^{1/3}) around a backward middle one.
    const long double p = 1.0L / (4.0L - cbrt4);
    c.emplace_back("suzuki4", 4, std::vector<long double>{p, p},
                   "Suzuki, Phys. Lett. A 146 (1990) 319: the five-stage fractal");
    c.emplace_back("kahan_li6", 6,
                   std::vector<long double>{0.39216144400731413927925056L, 0.33259913678935943859974864L,
                                            -0.70624617255763935980996482L, 0.08221359629355080023149045L},
                   "Kahan & Li, Math. Comp. 66 (1997) 1089: s9odr6a");
    c.emplace_back("mclachlan8", 8,
                   std::vector<long double>{0.74167036435061295344822780L, -0.40910082580003159399730010L,
                                            0.19075471029623837995387626L, -0.57386247111608226665638773L,
                                            0.29906418130365592384446354L, 0.33462491824529818378495798L,
                                            0.31529309239676659663205666L},
                   "McLachlan, SIAM J. Sci. Comput. 16 (1995) 151: s15odr8");
    c.emplace_back("kahan_li8", 8,
                   std::vector<long double>{0.13020248308889008087881763L, 0.56116298177510838456196441L,
                                            -0.38947496264484728640807860L, 0.15884190655515560089621075L,
                                            -0.39590389413323757733623154L, 0.18453964097831570709183254L,
                                            0.25837438768632204729397911L, 0.29501172360931029887096624L},
                   "Kahan & Li, Math. Comp. 66 (1997) 1089: s17odr8a");
    // Near-integrable tables: for the 3-stage bases (sv, 2s, rks) whose drift is an exact integrable flow.
    for (int n = 2; n <= 4; ++n)
      c.emplace_back("saba" + std::to_string(n), 2 * n, near_integrable::saba(n),
                     "Laskar & Robutel, Celest. Mech. Dyn. Astron. 80 (2001) 39: SABA_" + std::to_string(n) +
                         ", kicks at the Gauss-Legendre nodes; error O(eps h^" + std::to_string(2 * n) + " + eps^2 h^2)");
    for (int n = 2; n <= 4; ++n)
      c.emplace_back("sbab" + std::to_string(n), 2 * n, near_integrable::sbab(n),
                     "Laskar & Robutel, Celest. Mech. Dyn. Astron. 80 (2001) 39: SBAB_" + std::to_string(n) +
                         ", kicks at the Gauss-Lobatto nodes; error O(eps h^" + std::to_string(2 * n) + " + eps^2 h^2)");
    return c;
  }();
  return compositions;
}

inline std::string known_compositions() {
  std::string known;
  for (const auto& c : builtin_compositions()) known += (known.empty() ? "" : ", ") + c.name();
  return known;
}

// "" means "none".
inline const Composition& builtin_composition(const std::string& name) {
  const std::string key = name.empty() ? "none" : name;
  for (const auto& c : builtin_compositions())
    if (c.name() == key) return c;
  throw std::invalid_argument("composition: unknown composition '" + name + "' (known: " + known_compositions() + ")");
}

}  // namespace raydamp
