// The constraint solve's matrices, G1 M^{-1} G0^T (k x k), as band matrices in an order of the constraints
// found once from the pattern (reverse Cuthill-McKee): a chain of rods is tridiagonal, a double pendulum is
// 2 x 2, a molecule's bonds have a band of a few. Formed from the Jacobians' non-zeros through a list of
// products fixed at construction, factored in place by LU without pivoting (the matrices are G M^{-1} G^T,
// symmetric positive definite, or within O(h) of it), O(k b^2) for a band b, and nothing allocated after
// the workspace is sized.
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

namespace raydamp::constraints {

// One non-zero of M^{-1}: the mass kinds give theirs (constrained_system.hpp).
struct InverseMassEntry {
  int i, j;
  double value;
};

// How G1 M^{-1} G0^T is formed and stored: entry (a, b) += G1[left] M^{-1}(i, j) G0[right] for every pair
// of Jacobian non-zeros (left in row a at column i, right in row b at column j) with M^{-1}(i, j) != 0.
struct NormalPattern {
  struct Term {
    int left, right, slot;
    double inverse_mass;
  };
  int k = 0;
  int band = 0;                // b: entries (a, c) with |a - c| > b (in band order) are zero
  int width = 1;               // 2 b + 1
  std::vector<int> position;   // constraint a sits at row position[a] of the band matrix
  bool given_order = true;     // position[a] == a
  std::vector<Term> terms;     // the upper triangle's terms (a <= c in band order) first,
  int upper_terms = 0;         // then the lower's: a symmetric product needs only the first upper_terms

  NormalPattern() = default;
  // rows, cols: the Jacobian's non-zeros (ConstraintSet), n coordinates.
  NormalPattern(int k_, const std::vector<int>& rows, const std::vector<int>& cols, int n,
                const std::vector<InverseMassEntry>& inverse_mass)
      : k(k_) {
    // Which Jacobian entries sit in each column, and so which constraints meet through M^{-1}.
    std::vector<std::vector<int>> in_column(n);
    for (std::size_t e = 0; e < cols.size(); ++e) in_column[cols[e]].push_back(static_cast<int>(e));
    std::vector<std::vector<int>> neighbours(k);
    std::vector<Term> all;
    for (const InverseMassEntry& m : inverse_mass) {
      if (m.value == 0.0) continue;
      for (int left : in_column[m.i])
        for (int right : in_column[m.j]) {
          all.push_back(Term{left, right, -1, m.value});
          if (rows[left] != rows[right]) neighbours[rows[left]].push_back(rows[right]);
        }
    }
    for (auto& list : neighbours) {
      std::sort(list.begin(), list.end());
      list.erase(std::unique(list.begin(), list.end()), list.end());
    }
    // The constraints' order: as given, or reverse Cuthill-McKee where that narrows the band.
    std::vector<int> given(k);
    for (int a = 0; a < k; ++a) given[a] = a;
    std::vector<int> rcm = reverse_cuthill_mckee(neighbours);
    position.assign(k, 0);
    const int given_band = bandwidth(neighbours, given), rcm_band = bandwidth(neighbours, rcm);
    const std::vector<int>& order = rcm_band < given_band ? rcm : given;
    for (int r = 0; r < k; ++r) position[order[r]] = r;
    given_order = &order == &given;
    band = std::min(given_band, rcm_band);
    width = 2 * band + 1;
    for (Term& t : all) {
      const int a = position[rows[t.left]], c = position[rows[t.right]];
      t.slot = a * width + (c - a + band);
    }
    std::stable_partition(all.begin(), all.end(), [&](const Term& t) {
      return position[rows[t.left]] <= position[rows[t.right]];
    });
    upper_terms = static_cast<int>(std::count_if(all.begin(), all.end(), [&](const Term& t) {
      return position[rows[t.left]] <= position[rows[t.right]];
    }));
    terms = std::move(all);
  }

  int size() const { return k * width; }

  // out = G1 M^{-1} G0^T in band storage (row a's entries at a * width .. + width, column c at c - a + band).
  // symmetric: G1 = G0, only the upper triangle's terms, mirrored.
  void form(const double* G1, const double* G0, double* out, bool symmetric) const {
    std::fill(out, out + size(), 0.0);
    const int count = symmetric ? upper_terms : static_cast<int>(terms.size());
    for (int s = 0; s < count; ++s) {
      const Term& t = terms[s];
      out[t.slot] += G1[t.left] * t.inverse_mass * G0[t.right];
    }
    if (symmetric)
      for (int a = 0; a < k; ++a)
        for (int c = a + 1; c <= std::min(a + band, k - 1); ++c) out[c * width + (a - c + band)] = out[a * width + (c - a + band)];
  }

  // LU in place, no pivoting, each pivot stored as its reciprocal (the solves multiply): false if a pivot
  // is zero or not finite, or (positive: for G M^{-1} G^T, which has lost rank then) not > 0.
  bool factor(double* a, bool positive = true) const {
    for (int i = 0; i < k; ++i) {
      double* row_i = a + i * width + band;  // row_i[c - i] = A(i, c)
      const double pivot = row_i[0];
      if (!(positive ? pivot > 0.0 : pivot != 0.0) || !std::isfinite(pivot)) return false;
      const double inverse = 1.0 / pivot;
      row_i[0] = inverse;
      const int last = std::min(i + band, k - 1);
      for (int r = i + 1; r <= last; ++r) {
        double* row_r = a + r * width + band;  // row_r[c - r] = A(r, c)
        const double l = row_r[i - r] * inverse;
        row_r[i - r] = l;
        for (int c = i + 1; c <= last; ++c) row_r[c - r] -= l * row_i[c - i];
      }
    }
    return true;
  }

  // x <- A^{-1} x, A factored by factor(); x in band order.
  void solve(const double* a, double* x) const {
    if (band == 1) {  // tridiagonal (a chain of rods, a double pendulum): no inner loops
      for (int i = 1; i < k; ++i) x[i] -= a[i * 3] * x[i - 1];
      x[k - 1] *= a[(k - 1) * 3 + 1];
      for (int i = k - 2; i >= 0; --i) x[i] = (x[i] - a[i * 3 + 2] * x[i + 1]) * a[i * 3 + 1];
      return;
    }
    for (int i = 0; i < k; ++i) {
      const double* row_i = a + i * width + band;
      double s = x[i];
      for (int c = std::max(0, i - band); c < i; ++c) s -= row_i[c - i] * x[c];
      x[i] = s;
    }
    for (int i = k - 1; i >= 0; --i) {
      const double* row_i = a + i * width + band;
      double s = x[i];
      for (int c = i + 1; c <= std::min(i + band, k - 1); ++c) s -= row_i[c - i] * x[c];
      x[i] = s * row_i[0];
    }
  }

 private:
  static int bandwidth(const std::vector<std::vector<int>>& neighbours, const std::vector<int>& order) {
    std::vector<int> at(order.size());
    for (std::size_t r = 0; r < order.size(); ++r) at[order[r]] = static_cast<int>(r);
    int b = 0;
    for (std::size_t a = 0; a < neighbours.size(); ++a)
      for (int c : neighbours[a]) b = std::max(b, std::abs(at[a] - at[c]));
    return b;
  }

  // Breadth first from a least-connected constraint of each component, neighbours by degree, reversed.
  static std::vector<int> reverse_cuthill_mckee(const std::vector<std::vector<int>>& neighbours) {
    const int k = static_cast<int>(neighbours.size());
    std::vector<int> order;
    order.reserve(k);
    std::vector<char> seen(k, 0);
    auto degree = [&](int a) { return neighbours[a].size(); };
    for (;;) {
      int start = -1;
      for (int a = 0; a < k; ++a)
        if (!seen[a] && (start < 0 || degree(a) < degree(start))) start = a;
      if (start < 0) break;
      std::size_t head = order.size();
      order.push_back(start);
      seen[start] = 1;
      for (; head < order.size(); ++head) {
        std::vector<int> next;
        for (int c : neighbours[order[head]])
          if (!seen[c]) next.push_back(c), seen[c] = 1;
        std::stable_sort(next.begin(), next.end(), [&](int x, int y) { return degree(x) < degree(y); });
        order.insert(order.end(), next.begin(), next.end());
      }
    }
    std::reverse(order.begin(), order.end());
    return order;
  }
};

}  // namespace raydamp::constraints
