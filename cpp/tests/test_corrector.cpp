// The symplectic correctors (methods/corrector.hpp): coefficients against their closed form where there is one
// (order 4: one factor, a = 1, 2 b a = 1/24), the conditions each table must meet, the map's inverse exact
// to rounding on interacting planets, and the orders refused.
#include <cmath>

#include "check.hpp"
#include "raydamp/methods/corrector.hpp"
#include "raydamp/models/planets.hpp"

using namespace raydamp;

int main() {
  {
    const Corrector c(4);
    CHECK(c.a.size() == 1 && c.a[0] == 1.0 && std::abs(c.b[0] - 1.0 / 48) <= 1e-17);
  }
  // sum_i 2 b_i a_i^k / k! = -g_k for k = 1, 3, ..., 2n - 1, recomputed here in double
  const double g[] = {-1.0 / 24, 7.0 / 5760, -31.0 / 967680, 127.0 / 154828800};
  for (int order : {4, 6, 8, 10}) {
    const Corrector c(order);
    CHECK(static_cast<int>(c.a.size()) == order / 2 - 1);
    double factorial = 1;
    for (std::size_t j = 0; j < c.a.size(); ++j) {
      if (j > 0) factorial *= (2.0 * j) * (2.0 * j + 1);
      double s = 0;
      for (std::size_t i = 0; i < c.a.size(); ++i) s += 2 * c.b[i] * std::pow(c.a[i], 2 * j + 1) / factorial;
      CHECK(std::abs(s + g[j]) <= 1e-13 * std::abs(g[j]));
    }
  }
  // C^{-1}(C(z)) = z on two interacting planets, and C moves z by O(eps h^2)
  {
    const Planets model(1.0, 1.0, {1e-3, 2e-3}, 2, {0.0, 0.0});
    Planets::Vec q(4), p(4);
    q << 1.0, 0.1, -0.3, 1.7;
    p << -0.05e-3, 1.0e-3, -1.4e-3, -0.2e-3;
    for (int order : {4, 6, 8, 10}) {
      Planets::Vec x = q, y = p;
      const Corrector c(order);
      apply_corrector(model, c, 0.1, false, x, y);
      const double moved = (x - q).norm();
      CHECK(moved > 1e-9 && moved < 1e-5);
      apply_corrector(model, c, 0.1, true, x, y);
      CHECK((x - q).norm() <= 1e-15 && (y - p).norm() <= 1e-18);
    }
  }
  CHECK(test::throws([] { Corrector c(3); }));
  CHECK(test::throws([] { Corrector c(12); }));
  return test::failures == 0 ? 0 : 1;
}
