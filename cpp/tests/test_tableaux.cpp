// Every tableau is validated when built and its order is computed from the order
// conditions; these tests pin the computed orders and the refusals.
#include <stdexcept>

#include "check.hpp"
#include "raydamp/catalogue.hpp"

using namespace raydamp;

using raydamp::test::throws;

int main() {
  CHECK(builtin_tableau("euler").order() == 1);
  CHECK(builtin_tableau("heun").order() == 2);
  CHECK(builtin_tableau("midpoint").order() == 2);
  CHECK(builtin_tableau("rk4").order() == 4);
  CHECK(builtin_tableau("rk4").is_explicit());
  CHECK(builtin_tableau("midpoint").kind() == TableauKind::diagonally_implicit);

  // A one-digit slip in rk4's weights must show as a lower order, not pass silently.
  ButcherTableau slipped("rk4-slip", {{0, 0, 0, 0}, {0.5, 0, 0, 0}, {0, 0.5, 0, 0}, {0, 0, 1.0, 0}},
                         {1.0 / 6, 1.0 / 3, 1.0 / 3 + 1e-3, 1.0 / 6 - 1e-3}, {0, 0.5, 0.5, 1.0});
  CHECK(slipped.order() < 4);

  CHECK(throws([] { ButcherTableau("bad-c", {{0, 0}, {1.0, 0}}, {0.5, 0.5}, {0, 0.9}); }));
  CHECK(throws([] { ButcherTableau("bad-b", {{0, 0}, {1.0, 0}}, {0.5, 0.4}, {0, 1.0}); }));
  CHECK(throws([] { ButcherTableau("bad-shape", {{0, 0}}, {0.5, 0.5}, {0, 1.0}); }));
  CHECK(throws([] { builtin_tableau("rk45"); }));

  // The catalogue's orders follow from the tableau and the splitting.
  CHECK(method_order(method_entry("rks"), builtin_tableau("euler")) == 1);
  CHECK(method_order(method_entry("rks"), builtin_tableau("rk4")) == 2);
  CHECK(method_order(method_entry("rk4"), builtin_tableau("rk4")) == 4);
  CHECK(method_order(method_entry("3s"), builtin_tableau("euler")) == 2);
  CHECK(throws([] { resolve_tableau(method_entry("rksb"), "midpoint"); }));
  CHECK(throws([] { resolve_tableau(method_entry("3s"), "heun"); }));
  CHECK(throws([] { resolve_tableau(method_entry("heun"), "rk4"); }));
  CHECK(throws([] { method_entry("leapfrog"); }));
  CHECK(throws([] { require_applicable(method_entry("sv"), 0.5); }));
  require_applicable(method_entry("sv"), 0.0);
  require_applicable(method_entry("3s"), 0.5);
  CHECK(resolve_tableau(method_entry("rks"), "midpoint").name() == "midpoint");

  // A user's tableau: validated like ours, named by its coefficients, found by that name, and
  // held to what the method can run.
  const ButcherTableau& kutta3 = define_tableau({{0, 0, 0}, {0.5, 0, 0}, {-1, 2, 0}}, {1.0 / 6, 2.0 / 3, 1.0 / 6},
                                                {0, 0.5, 1});
  CHECK(kutta3.order() == 3 && kutta3.name().rfind("custom-", 0) == 0 && kutta3.name().size() == 23);
  CHECK(&define_tableau({{0, 0, 0}, {0.5, 0, 0}, {-1, 2, 0}}, {1.0 / 6, 2.0 / 3, 1.0 / 6}, {0, 0.5, 1}) == &kutta3);
  CHECK(&tableau_named(kutta3.name()) == &kutta3);
  CHECK(&resolve_tableau(method_entry("rk"), kutta3.name()) == &kutta3);
  CHECK(define_tableau({{0.5}}, {1.0}, {0.5}).name() != kutta3.name());
  CHECK(throws([] { define_tableau({{0, 0}, {0.6, 0}}, {0.5, 0.5}, {0, 1}); }));  // row 1 misses c[1]
  CHECK(throws([] { tableau_named("custom-0000000000000000"); }));
  const ButcherTableau& gauss2 = define_tableau({{0.25, 0.25 - 0.2886751345948129}, {0.25 + 0.2886751345948129, 0.25}},
                                                {0.5, 0.5}, {0.5 - 0.2886751345948129, 0.5 + 0.2886751345948129});
  CHECK(gauss2.kind() == TableauKind::implicit && gauss2.order() == 4);
  CHECK(throws([&] { resolve_tableau(method_entry("rks"), gauss2.name()); }));  // fully implicit
  CHECK(throws([&] { resolve_tableau(method_entry("rk"), define_tableau({{0.5}}, {1.0}, {0.5}).name()); }));

  // Palindromes are derived from their half: the tables really are symmetric.
  CHECK(is_symmetric(ThreeTermSplitting::stages));
  CHECK(ThreeTermSplitting::stages.size() == 5);
  CHECK(ThreeTermSplitting::stages[4].flow == Flow::damp && ThreeTermSplitting::stages[4].fraction == 0.5);
  TEST_MAIN_RETURN();
}
