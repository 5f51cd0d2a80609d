// The hysteretic materials (materials/materials.hpp) and the structure with springs (models/structure.hpp):
// - elastic-plastic and bilinear: forces on a loading-unloading cycle against values worked by hand, the
//   bilinear's loops between its asymptotes sigma = b k d +- (1 - b) fy, a softening b < 0;
// - Bouc-Wen (n = 1): the closed-form return map against a fine RK4 integration of dz/dd along a path
//   with reversals and crossings of z = 0, to 1e-11;
// - Bouc-Wen's vector return maps (bouc_wen_lanes.hpp): the Pade phi1 against expm1, and each spring's force
//   and trial state equal to BoucWen::force's bits over random states and steps (short, long, zero, crossing z = 0),
//   the same bits wherever the spring stands in the set;
// - trial and commit: a force answers from the committed state whatever trials came before it;
// - the phases of kink location (materials/phases.hpp): each law equals the return map along a monotonic
//   drift inside its range, meets the next phase's law at the kink without a jump, and its range ends where
//   the return map's law changes; the cubic root finder of kinks.hpp finds the first rise to rounding;
// - a structure without springs steps as its LinearStructure bit for bit; with springs, a run does not
//   change the model it was given (its materials are the run's own), two runs give the same bits, and
//   the gradient allocates nothing.
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "check.hpp"
#include "counting_new.hpp"
#include "raydamp/ensemble/driver.hpp"
#include "raydamp/materials/kinks.hpp"
#include "raydamp/models/structure.hpp"
#include "raydamp/raydamp.hpp"

using namespace raydamp;
using namespace raydamp::materials;
using Vec = Eigen::VectorXd;

namespace {

// sigma along the deformations ds, each step a commit: the force after each.
template <class Material>
std::vector<double> path_forces(const Material& m, const std::vector<double>& ds) {
  typename Material::State c, t;
  std::vector<double> out;
  for (double d : ds) {
    out.push_back(m.force(c, d, t));
    c = t;
  }
  return out;
}

void elastic_plastic() {
  const ElasticPlastic m{10.0, 7.5};  // d_y = 0.75
  // load to 2 (yields at 0.75: d_p = 1.25), unload to 0 (sigma = -12.5 clipped to -7.5: d_p = 0.75),
  // reload to 1 (sigma = 2.5, elastic).
  const auto f = path_forces(m, {0.5, 2.0, 1.0, 0.0, 1.0});
  CHECK_NEAR(f[0], 5.0, 1e-15);
  CHECK_NEAR(f[1], 7.5, 1e-15);
  CHECK_NEAR(f[2], 7.5 - 10.0, 1e-14);
  CHECK_NEAR(f[3], -7.5, 1e-15);
  CHECK_NEAR(f[4], 2.5, 1e-14);
  ElasticPlastic::State s;
  s.plastic = 1.25;
  const Range r = m.elastic_range(s);
  CHECK_NEAR(r.lower, 0.5, 1e-15);
  CHECK_NEAR(r.upper, 2.0, 1e-15);
}

void bilinear() {
  const double k = 10.0, fy = 7.5, b = 0.1;
  const Bilinear m(k, fy, b);
  // Monotonic loading past yield lies on the upper asymptote, unloading by 2 d_y ends on the lower one.
  const auto f = path_forces(m, {3.0, 3.0 - 2.0 * 0.75, 3.0 - 2.0 * 0.75 - 1.0, 5.0});
  CHECK_NEAR(f[0], b * k * 3.0 + (1 - b) * fy, 1e-13);
  CHECK_NEAR(f[1], f[0] - 2.0 * fy, 1e-13);  // elastic unloading by exactly 2 fy reaches the lower line
  CHECK_NEAR(f[1], b * k * 1.5 - (1 - b) * fy, 1e-13);
  CHECK_NEAR(f[2], b * k * 0.5 - (1 - b) * fy, 1e-13);
  CHECK_NEAR(f[3], b * k * 5.0 + (1 - b) * fy, 1e-13);
  // b = 0 is the elastic-plastic material.
  const Bilinear flat(k, fy, 0.0);
  const ElasticPlastic epp{k, fy};
  const std::vector<double> path = {0.3, 1.7, -0.2, -2.5, 0.4, 3.3, 2.9};
  const auto a = path_forces(flat, path), e = path_forces(epp, path);
  for (std::size_t i = 0; i < path.size(); ++i) CHECK_NEAR(a[i], e[i], 1e-14);
  // Softening (b = -0.2): past yield the force falls by 0.2 k per unit of d.
  const Bilinear soft(k, fy, -0.2);
  const auto g = path_forces(soft, {1.0, 2.0});
  CHECK_NEAR(g[0], -0.2 * k * 1.0 + 1.2 * fy, 1e-13);
  CHECK_NEAR(g[1] - g[0], -0.2 * k, 1e-13);
}

// dz/dd of Bouc-Wen n = 1 along a drift of sign s.
double bouc_wen_rate(const BoucWen& m, double z, double s) {
  const double dy = m.fy / m.k;
  return (1.0 - (m.beta * (s * z >= 0.0 ? 1.0 : -1.0) + m.gamma) * std::abs(z)) / dy;
}

// z after a drift from d0 to d1 from z0, by RK4 with steps of at most 1e-5 (the rate is smooth in z except
// at z = 0, which the fine steps cross with an error far below the tolerance checked).
double bouc_wen_rk4(const BoucWen& m, double z, double d0, double d1) {
  const double s = d1 > d0 ? 1.0 : -1.0;
  const int n = static_cast<int>(std::ceil(std::abs(d1 - d0) / 1e-5));
  const double h = (d1 - d0) / n;
  for (int i = 0; i < n; ++i) {
    const double k1 = bouc_wen_rate(m, z, s), k2 = bouc_wen_rate(m, z + 0.5 * h * k1, s),
                 k3 = bouc_wen_rate(m, z + 0.5 * h * k2, s), k4 = bouc_wen_rate(m, z + h * k3, s);
    z += h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4);
  }
  return z;
}

void bouc_wen() {
  for (const auto& [beta, gamma] : {std::pair{0.5, 0.5}, std::pair{0.7, -0.3}, std::pair{0.25, 0.75}}) {
    const BoucWen m(10.0, 7.5, 0.1, beta, gamma);
    const std::vector<double> path = {0.4, 2.5, 1.0, -1.8, -0.3, 0.9, 0.85};
    BoucWen::State c, t;
    double z_ref = 0.0, d_prev = 0.0;
    for (double d : path) {
      const double sigma = m.force(c, d, t);
      z_ref = bouc_wen_rk4(m, z_ref, d_prev, d);
      CHECK_NEAR(t.z, z_ref, 1e-11);
      CHECK_NEAR(sigma, m.alpha * m.k * d + (1 - m.alpha) * m.fy * z_ref, 1e-10);
      CHECK(std::abs(t.z) <= 1.0 / (beta + gamma) + 1e-15);
      c = t;
      d_prev = d;
    }
  }
}

// The kick's vector return maps of Bouc-Wen springs against BoucWen::force, the return map of materials.hpp.
void bouc_wen_lanes_match_the_return_map() {
  double worst = 0.0;
  for (int i = -5000; i <= 5000; ++i) {
    const double x = bouc_wen_lanes::kBound * i / 5000.0;
    const long double exact = i == 0 ? 1.0L : std::expm1(static_cast<long double>(x)) / x;
    worst = std::max(worst, static_cast<double>(std::abs(bouc_wen_lanes::pade_phi1(x) / exact - 1.0L)));
  }
  CHECK(worst <= 6e-16);  // measured 4.9e-16 (2.2 ulp), at x near 1/2

  std::mt19937_64 rng(42);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  for (const auto& [beta, gamma] : {std::pair{0.5, 0.5}, std::pair{0.7, -0.3}, std::pair{0.25, 0.75}}) {
    const int n = 7;  // three blocks of two, and one padded
    std::vector<BoucWen> m;
    for (int s = 0; s < n; ++s) m.emplace_back(10.0 * (1 + s), 7.5 + s, 0.1 * s, beta, gamma);
    bouc_wen_lanes::Params all;
    std::vector<bouc_wen_lanes::Params> one(n);
    for (int s = 0; s < n; ++s) {
      all.add(m[s]);
      one[s].add(m[s]);
    }
    for (int trial = 0; trial < 3000; ++trial) {
      std::vector<BoucWen::State> c(n), two(n), alone(n), reference(n), narrow(n), wide(n);
      const std::size_t padded = bouc_wen_lanes::Params::padded(n);
      std::vector<double> d(n), out_two(padded), out_alone(n * bouc_wen_lanes::kWidest), out_narrow(padded),
          out_wide(padded);
      for (int s = 0; s < n; ++s) {
        const double dy = m[s].fy / m[s].k, bound = 1.0 / (beta + gamma);
        c[s] = {3.0 * dy * unit(rng), bound * unit(rng)};
        // steps of 1e-6 to 2 d_y (|x| = c D past kBound on some), zero, and from below z = 0 past it
        const double scale = std::pow(10.0, -6.0 + 6.3 * (0.5 + 0.5 * unit(rng)));
        d[s] = trial % 7 == 0 ? c[s].d : c[s].d + dy * scale * unit(rng);
      }
      bouc_wen_lanes::forces(m.data(), all, c.data(), d.data(), two.data(), out_two.data(), n);
      // Each width's lanes alone, whichever the processor's forces() takes: two to a vector, and four (AVX2).
      const bool narrow_slow = bouc_wen_lanes::common_forces2(all, c.data(), d.data(), narrow.data(),
                                                              out_narrow.data(), n);
#if defined(__x86_64__) || defined(__i386__)
      const bool four = has_avx2();
      const bool wide_slow = four && bouc_wen_lanes::common_forces4(all, c.data(), d.data(), wide.data(),
                                                                    out_wide.data(), n);
#else
      const bool four = false, wide_slow = false;
#endif
      bool slow = false;
      for (int s = 0; s < n; ++s) {
        const std::size_t at = s * bouc_wen_lanes::kWidest;
        bouc_wen_lanes::forces(&m[s], one[s], &c[s], &d[s], &alone[s], &out_alone[at], 1);
        // The scalar return map takes the lanes' operations on the common step and hands them the others, so
        // the kick's force and every other reader's are the same bits (they were 1 ulp apart, the scalar map
        // then taking phi.hpp's series).
        CHECK(out_two[s] == m[s].force(c[s], d[s], reference[s]));
        CHECK(two[s].z == reference[s].z);
        // and the force is sigma(d): elastic d + hysteretic z
        BoucWen::State check;
        CHECK(m[s].force(c[s], d[s], check) == m[s].elastic * d[s] + m[s].hysteretic * two[s].z);
        CHECK(two[s].d == d[s]);
        CHECK(out_two[s] == out_alone[at] && two[s].z == alone[s].z);  // the same bits alone as in the set
        double z;
        if (m[s].common_step(c[s], d[s], z)) {
          CHECK(out_narrow[s] == out_two[s] && narrow[s].z == two[s].z && narrow[s].d == d[s]);
          if (four) CHECK(out_wide[s] == out_two[s] && wide[s].z == two[s].z && wide[s].d == d[s]);
        } else {
          slow = true;
        }
      }
      CHECK(narrow_slow == slow);
      if (four) CHECK(wide_slow == slow);
    }
  }
}

// Trials never move the committed state: the force at d is the same after any trials.
void trial_and_commit() {
  const Bilinear m(10.0, 7.5, 0.05);
  Bilinear::State c, t, u;
  const double direct = m.force(c, 2.0, t);
  m.force(c, 5.0, u);
  m.force(c, -4.0, u);
  CHECK(m.force(c, 2.0, u) == direct);
  CHECK(u.plastic == t.plastic && u.back == t.back);
}

// A 3-DOF shear frame: storeys as springs (ground to 0, 0 to 1, 1 to 2), lumped mass.
Structure<LumpedMass> frame(bool with_springs, SparseColMajor& k_out) {
  const int n = 3;
  Vec m(n);
  m << 1.0, 1.5, 0.8;
  Springs springs;
  SparseColMajor k(n, n);
  if (with_springs) {
    springs.bilinear.add(-1, 0, Bilinear(40.0, 1.0, 0.05));
    springs.elastic_plastic.add(0, 1, ElasticPlastic{30.0, 0.8});
    springs.bouc_wen.add(1, 2, BoucWen(20.0, 0.6, 0.1, 0.5, 0.5));
  } else {
    std::vector<Eigen::Triplet<double>> t = {{0, 0, 70.0}, {0, 1, -30.0}, {1, 0, -30.0}, {1, 1, 50.0},
                                             {1, 2, -20.0}, {2, 1, -20.0}, {2, 2, 20.0}};
    k.setFromTriplets(t.begin(), t.end());
  }
  k_out = k;
  return Structure<LumpedMass>(LumpedMass(m, "M"), k, springs, Vec::Zero(n), 0.3, 0.002);
}

void structure_runs() {
  SparseColMajor k;
  // Without springs a Structure is its LinearStructure: the same bits.
  const auto plain = frame(false, k);
  const LinearStructure<LumpedMass> linear(plain.mass, k, Vec::Zero(3), 0.3, 0.002);
  Vec q0(3), p0(3);
  q0 << 0.01, -0.02, 0.03;
  p0 << 2.0, -1.0, 1.5;
  RunSpec spec{0.01, 500, 0.01, 50, false};
  const auto& tab = builtin_tableau("euler");
  const auto& none = builtin_composition("none");
  const RunResult a = integrate_model<ThreeTermSplitting>(plain, tab, none, State<Eigen::Dynamic>{q0, p0}, spec, {});
  const RunResult b = integrate_model<ThreeTermSplitting>(linear, tab, none, State<Eigen::Dynamic>{q0, p0}, spec, {});
  CHECK(a.trajectory.q == b.trajectory.q && a.trajectory.p == b.trajectory.p);

  // With springs: the springs yield (p0 large), the model's own states stay virgin, two runs agree.
  const auto yielding = frame(true, k);
  for (const char* composition : {"none", "yoshida4"}) {
    const auto& comp = builtin_composition(composition);
    const RunResult r1 = integrate_model<ThreeTermSplitting>(yielding, tab, comp, State<Eigen::Dynamic>{q0, p0}, spec, {});
    const RunResult r2 = integrate_model<ThreeTermSplitting>(yielding, tab, comp, State<Eigen::Dynamic>{q0, p0}, spec, {});
    CHECK(r1.status == Status::completed);
    CHECK(r1.trajectory.q == r2.trajectory.q);
    CHECK(yielding.springs.bilinear.committed[0].plastic == 0.0);
  }
  // Merged and unmerged steps commit alike: the same trajectory to rounding.
  for (bool merge : {true, false}) {
    RunSpec s = spec;
    s.merge_steps = merge;
    const RunResult r = integrate_model<Baoab>(yielding, tab, none, State<Eigen::Dynamic>{q0, p0}, s, {});
    static std::vector<double> first;
    if (merge) first = r.trajectory.q;
    else
      for (std::size_t i = 0; i < first.size(); ++i) CHECK_NEAR(r.trajectory.q[i], first[i], 1e-12);
  }
  // The elastic ranges from the committed states: virgin, each spring's is [-fy/k, fy/k] (Bouc-Wen: unbounded).
  std::vector<double> lower(3), upper(3);
  yielding.elastic_ranges(lower.data(), upper.data());
  CHECK_NEAR(upper[0], 0.8 / 30.0, 1e-15);  // kind order: the elastic-plastic spring first
  CHECK_NEAR(lower[1], -1.0 / 40.0, 1e-15);
  CHECK(std::isinf(upper[2]));
  // The springs' gradient allocates nothing.
  Vec g = Vec::Zero(3), q = q0;
  yielding.gradient(q, g);
  const long before = allocations.load();
  for (int i = 0; i < 100; ++i) {
    q[0] += 1e-3;
    yielding.gradient(q, g);
    yielding.springs.commit();
  }
  CHECK(allocations.load() == before);
  // A spring on a coordinate outside the structure is refused, naming it.
  Springs bad;
  bad.elastic_plastic.add(0, 3, ElasticPlastic{1.0, 1.0});
  bool named = false;
  try {
    Structure<LumpedMass>(LumpedMass(Vec::Ones(3), "M"), SparseColMajor(3, 3), bad, Vec::Zero(3), 0.0, 0.0);
  } catch (const std::invalid_argument& e) {
    named = std::string(e.what()).rfind("springs[0].dofs", 0) == 0;
  }
  CHECK(named);
}

}  // namespace

// Phase laws against the return maps: from a state, a drift up to d inside the phase's range (the return map
// exact for it), then past the range's end in the next phase.
void phases() {
  {
    const ElasticPlastic m{10.0, 7.5};
    ElasticPlastic::State c, t;
    const Range r = phase_range(m, c, 0);
    CHECK_NEAR(r.upper, 0.75, 1e-16);
    CHECK_NEAR(phase_force(m, c, 0, 0.5), m.force(c, 0.5, t), 1e-15);
    const int up = phase_after_exit(m, c, 0, true);
    CHECK(up == 1);
    CHECK_NEAR(phase_force(m, c, up, r.upper), phase_force(m, c, 0, r.upper), 1e-14);  // no jump at yield
    CHECK_NEAR(phase_force(m, c, up, 2.0), m.force(c, 2.0, t), 1e-15);
    const ElasticPlastic::State at = phase_state(m, c, up, 2.0);
    CHECK_NEAR(at.plastic, t.plastic, 1e-15);
    CHECK(phase_after_reversal(m, at, up) == 0);
    CHECK_NEAR(phase_force(m, at, 0, 2.0), 7.5, 1e-14);  // unloading starts at fy
  }
  {
    const Bilinear m(10.0, 7.5, 0.1);
    Bilinear::State c, t;
    const double yield = phase_range(m, c, 0).lower;
    CHECK_NEAR(phase_force(m, c, -1, yield), phase_force(m, c, 0, yield), 1e-14);
    CHECK_NEAR(phase_force(m, c, -1, -3.0), m.force(c, -3.0, t), 1e-14);
    const Bilinear::State at = phase_state(m, c, -1, -3.0);
    CHECK_NEAR(at.plastic, t.plastic, 1e-15);
    CHECK_NEAR(at.back, t.back, 1e-14);
  }
  {
    const BoucWen m(10.0, 7.5, 0.1, 0.6, 0.3);
    BoucWen::State c, t;
    c.z = -0.5;  // w < 0 on an upward drift: phase +1 until z = 0, then +2
    const Range r = phase_range(m, c, 1);
    CHECK(std::isinf(r.lower) && r.upper > 0.0);
    CHECK_NEAR(phase_z(m, c, 1, r.upper), 0.0, 1e-14);
    CHECK_NEAR(phase_force(m, c, 1, 0.5 * r.upper), m.force(c, 0.5 * r.upper, t), 1e-14);
    const BoucWen::State at = phase_state(m, c, 1, r.upper);
    CHECK(phase_after_exit(m, at, 1, true) == 2);
    CHECK_NEAR(phase_force(m, at, 2, 3.0), m.force(c, 3.0, t), 1e-13);  // the two pieces make the return map
    CHECK(phase_after_reversal(m, phase_state(m, at, 2, 3.0), 2) == -1);
  }
  // first_rise: g = (s - 0.3)(s + 1)(2 - s) rises through 0 at 0.3 only; -g never rises in (0, 1]
  const kinks::Cubic g{-0.6, 1.7, 1.3, -1.0};
  CHECK_NEAR(kinks::first_rise(g), 0.3, 1e-15);
  CHECK(kinks::first_rise({0.6, -1.7, -1.3, 1.0}) == kinks::kNone);
  // a touch: g = -(s - 0.5)^2 + 1e-6 rises at 0.5 - 1e-3, inside the step, with both ends negative
  CHECK_NEAR(kinks::first_rise({-0.25 + 1e-6, 1.0, -1.0, 0.0}), 0.5 - 1e-3, 1e-12);
}

int main() {
  phases();
  elastic_plastic();
  bilinear();
  bouc_wen();
  bouc_wen_lanes_match_the_return_map();
  trial_and_commit();
  structure_runs();
  if (raydamp::test::failures) std::printf("%d check(s) failed\n", raydamp::test::failures);
  return raydamp::test::failures ? 1 : 0;
}
