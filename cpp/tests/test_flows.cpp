// Each exact sub-flow against a fine classical RK4 solution of its own ODE, on both models.
#include <cmath>
#include <limits>

#include "check.hpp"
#include "raydamp/raydamp.hpp"

using namespace raydamp;

// Integrates z' = f(z) by RK4 with many small steps: the reference for one sub-flow.
template <int Dim, class F>
State<Dim> reference(State<Dim> z, double t, F f, int steps = 4000) {
  const double h = t / steps;
  for (int i = 0; i < steps; ++i) {
    State<Dim> k1 = f(z), z2 = z, k2, z3 = z, k3, z4 = z, k4;
    z2.q += 0.5 * h * k1.q; z2.p += 0.5 * h * k1.p; k2 = f(z2);
    z3.q += 0.5 * h * k2.q; z3.p += 0.5 * h * k2.p; k3 = f(z3);
    z4.q += h * k3.q; z4.p += h * k3.p; k4 = f(z4);
    z.q += h / 6 * (k1.q + 2 * k2.q + 2 * k3.q + k4.q);
    z.p += h / 6 * (k1.p + 2 * k2.p + 2 * k3.p + k4.p);
  }
  return z;
}

template <class Model, int Dim = Model::dim>
void check_flows(const Model& model, State<Dim> z0, double t) {
  Workspace<Dim> ws(model.size(), 1);
  auto field = [&](bool drift, bool kick, bool damp) {
    return [&model, drift, kick, damp](const State<Dim>& z) {
      State<Dim> d{Vector<Dim>::Zero(), Vector<Dim>::Zero()};
      Vector<Dim> tmp;
      if (drift) model.mass.velocity(z.p, d.q);
      if (kick) { model.gradient(z.q, tmp); d.p -= tmp; }
      if (damp) { model.damping.rate(z.q, z.p, tmp); d.p -= tmp; }
      return d;
    };
  };
  auto distance = [](const State<Dim>& a, const State<Dim>& b) {
    return std::max((a.q - b.q).cwiseAbs().maxCoeff(), (a.p - b.p).cwiseAbs().maxCoeff());
  };
  State<Dim> z = z0;
  flows::drift(model, z, t, ws);
  CHECK_NEAR(distance(z, reference(z0, t, field(true, false, false))), 0.0, 1e-12);
  z = z0;
  flows::kick(model, z, t, ws);
  CHECK_NEAR(distance(z, reference(z0, t, field(false, true, false))), 0.0, 1e-12);
  z = z0;
  flows::damp(model, z, t, ws);
  CHECK_NEAR(distance(z, reference(z0, t, field(false, false, true))), 0.0, 1e-12);
  z = z0;
  flows::kick_damp(model, z, t, ws);
  CHECK_NEAR(distance(z, reference(z0, t, field(false, true, true))), 0.0, 1e-12);
}

// A damping kind that counts the factors it makes (damping/factors_cache.hpp keeps them per length).
struct CountingDamping {
  struct Factors {
    double t = std::numeric_limits<double>::quiet_NaN();
    double twice = 0.0;
  };
  mutable int made = 0;
  Factors factors(double t) const {
    ++made;
    return {t, 2.0 * t};
  }
};

// A composed whole step cycles through a few lengths (3s + suzuki4's damps: three); each is made once.
void check_factors_cache() {
  CountingDamping damping;
  FactorsCache<CountingDamping::Factors> cache;
  const double cycle[] = {0.05, 0.1, 0.3, 0.3, 0.1, 0.05};
  for (int step = 0; step < 100; ++step)
    for (double t : cycle) CHECK(cache.get(t, damping).twice == 2.0 * t);
  CHECK(damping.made == 3);
  // Six lengths fit (the last two and four earlier), in any order; a cycle of seven is made again and again.
  for (const int lengths : {6, 7}) {
    CountingDamping fresh;
    FactorsCache<CountingDamping::Factors> six;
    for (int step = 0; step < 100; ++step)
      for (int k = 0; k < 2 * lengths; ++k) {
        const double t = 1.0 + (k < lengths ? k : 2 * lengths - 1 - k);  // up the lengths and back down
        CHECK(six.get(t, fresh).twice == 2.0 * t);
      }
    if (lengths == 6) CHECK(fresh.made == 6);
    else CHECK(fresh.made > 100);
  }
  // A scalar damping's few numbers are made again past the last two lengths (no lock, no allocation to save).
  IsotropicDamping scalar{0.5};
  FactorsCache<DecayFactors> decay;
  for (double t : cycle) CHECK(decay.get(t, scalar).exp == std::exp(-0.5 * t));
}

int main() {
  check_factors_cache();
  for (double eps : {0.0, 1e-9, 0.01, 0.5, 3.0}) {
    DampedPendulum pendulum(eps);
    State<1> z{Vector<1>(2.0), Vector<1>(-0.7)};
    check_flows(pendulum, z, 0.8);
    ElasticPendulum elastic(eps, 1.3, 2.0, 0.9, {0.1, 0.0, -1.0});
    State<3> w{Vector<3>(0.3, 1.2, -0.6), Vector<3>(1.1, -0.4, 0.25)};
    check_flows(elastic, w, 0.8);
  }
  // phi1 across its series/expm1 switches (1e-3, 0.05), against long-double evaluation.
  for (double x : {-1e-3, -0.999e-3, 1e-3, -2e-5, -1e-5, -9.99e-6, -1e-8, 0.0, 1e-7, -0.0499, -0.05, 0.05, 0.3,
                   -0.4999, 0.5, -40.0}) {
    const long double xl = x;
    const double expected = x == 0.0 ? 1.0 : static_cast<double>(std::expm1(xl) / xl);
    CHECK_NEAR(phi1(x), expected, 4e-16 * std::abs(expected));
  }
  // eps -> 0: the exact kick+damp flow is the plain kick.
  {
    DampedPendulum tiny(1e-300), zero(0.0);
    State<1> a{Vector<1>(2.0), Vector<1>(-0.7)}, b = a;
    Workspace<1> ws(1, 1);
    flows::kick_damp(tiny, a, 0.3, ws);
    flows::kick(zero, b, 0.3, ws);
    CHECK(a.p[0] == b.p[0]);
  }
  TEST_MAIN_RETURN();
}
