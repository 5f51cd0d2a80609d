// The reference for bench_steps.py: the steps of 3s, 2s and rks (Heun tableau) on
// the damped pendulum and the elastic pendulum, written out by hand with plain
// doubles and <cmath>, no Eigen and no raydamp header.
//
// Each loop does the floating-point operations raydamp's sub-flows do, in the same
// order (so the final state should agree with raydamp's to the last bit, and
// bench_steps.py checks that it does to 1e-10), with one liberty a person writing
// the loop by hand takes: the step size is fixed, so exp, expm1 and phi1 of -h eps
// are computed once before the loop instead of in every step. The results are the
// same; the cost is not, and that difference is part of what the benchmark shows.
//
// usage: handwritten MODEL METHOD N_STEPS [h=H] [repeats=R] [eps=E] [q=a,b,c] [p=a,b,c]
//                    [m=M] [k=K] [l=L] [g=x,y,z]
//   MODEL   damped_pendulum | elastic_pendulum
//   METHOD  3s | 3s_merged | 2s | rks
// Prints the best ns per step over the repeats (each from the same initial state)
// and the final state at full precision.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

namespace {

// phi1(x) = (e^x - 1)/x with the Taylor series near 0, as raydamp/phi.hpp defines it.
double phi1(double x) {
  if (std::abs(x) < 1e-5) return 1.0 + x * (0.5 + x / 6.0);
  return std::expm1(x) / x;
}

// ---- Damped pendulum: q' = p, p' = -sin q - eps p (M = 1, so the drift is q += t p).

struct Pendulum {
  double eps;
  double q, p;
};

// 3s: damp h/2, drift h/2, kick h, drift h/2, damp h/2. A damp is p + (e^{-t eps} - 1) p, as raydamp's
// (damping/isotropic_damping.hpp: e^{-t eps} rounded would bias the decay rate).
void pendulum_3s(Pendulum& s, long n_steps, double h) {
  const double half = 0.5 * h;
  const double decay = std::expm1(-half * s.eps);
  double q = s.q, p = s.p;
  for (long i = 0; i < n_steps; ++i) {
    p += decay * p;
    q += half * p;
    p -= h * std::sin(q);
    q += half * p;
    p += decay * p;
  }
  s.q = q;
  s.p = p;
}

// 3s with first-same-as-last merging, as a person writes it for speed: the damp
// h/2 ending one step and the damp h/2 starting the next are one damp h.
void pendulum_3s_merged(Pendulum& s, long n_steps, double h) {
  const double half = 0.5 * h;
  const double decay_half = std::expm1(-half * s.eps), decay = std::expm1(-h * s.eps);
  double q = s.q, p = s.p;
  p += decay_half * p;
  for (long i = 0; i + 1 < n_steps; ++i) {
    q += half * p;
    p -= h * std::sin(q);
    q += half * p;
    p += decay * p;
  }
  q += half * p;
  p -= h * std::sin(q);
  q += half * p;
  p += decay_half * p;
  s.q = q;
  s.p = p;
}

// 2s: drift h/2, exact kick+damp h (p <- p + (e^{-h eps} - 1) p - h phi1(-h eps) sin q), drift h/2.
void pendulum_2s(Pendulum& s, long n_steps, double h) {
  const double half = 0.5 * h;
  const double x = -h * s.eps;
  const double decay = std::expm1(x);
  const double kick = h * phi1(x);
  double q = s.q, p = s.p;
  for (long i = 0; i < n_steps; ++i) {
    q += half * p;
    p += decay * p - kick * std::sin(q);
    q += half * p;
  }
  s.q = q;
  s.p = p;
}

// rks: drift h/2, one Heun step of p' = -sin q - eps p with q frozen, drift h/2.
// Heun written as raydamp writes it: the constant force once, the damping slopes
// k0 = -eps p and k1 = -eps (p - h g + h k0), then p - h g + h/2 k0 + h/2 k1.
void pendulum_rks(Pendulum& s, long n_steps, double h) {
  const double half = 0.5 * h;
  const double a = s.eps;
  double q = s.q, p = s.p;
  for (long i = 0; i < n_steps; ++i) {
    q += half * p;
    const double g = std::sin(q);
    const double k0 = -(a * p);
    const double k1 = -(a * ((p - h * g) + h * k0));
    p = ((p - h * g) + half * k0) + half * k1;
    q += half * p;
  }
  s.q = q;
  s.p = p;
}

// ---- Elastic pendulum: M = m I, V = k/2 (|q| - l)^2 - m g.q, damping only along q:
// A = (eps/m) u u^T with u = q/|q|.

struct Elastic {
  double eps, m, k, l;
  double g[3];
  double q[3], p[3];
};

double dot(const double* x, const double* y) { return x[0] * y[0] + x[1] * y[1] + x[2] * y[2]; }

struct ElasticConstants {
  double a, inverse_mass, k, l;
  double mg[3];
  explicit ElasticConstants(const Elastic& s)
      : a(s.eps / s.m), inverse_mass(1.0 / s.m), k(s.k), l(s.l), mg{s.m * s.g[0], s.m * s.g[1], s.m * s.g[2]} {}
};

// grad V(q) = k (1 - l/|q|) q - m g.
inline void elastic_gradient(const ElasticConstants& c, const double* q, double* grad) {
  const double spring = c.k * (1.0 - c.l / std::sqrt(dot(q, q)));
  for (int i = 0; i < 3; ++i) grad[i] = spring * q[i] - c.mg[i];
}

inline void elastic_drift(const ElasticConstants& c, double* q, const double* p, double t) {
  for (int i = 0; i < 3; ++i) q[i] += t * (c.inverse_mass * p[i]);
}

// 3s: damp h/2 (p += (e^{-h/2 a} - 1)(q.p/|q|^2) q), drift h/2, kick h, drift h/2, damp h/2.
void elastic_3s(Elastic& s, long n_steps, double h) {
  const ElasticConstants c(s);
  const double half = 0.5 * h;
  const double decay_m1 = std::expm1(-half * c.a);
  double q[3] = {s.q[0], s.q[1], s.q[2]}, p[3] = {s.p[0], s.p[1], s.p[2]}, grad[3];
  auto damp = [&] {
    const double radial = decay_m1 * dot(q, p) * (1.0 / dot(q, q));
    for (int i = 0; i < 3; ++i) p[i] += radial * q[i];
  };
  for (long n = 0; n < n_steps; ++n) {
    damp();
    elastic_drift(c, q, p, half);
    elastic_gradient(c, q, grad);
    for (int i = 0; i < 3; ++i) p[i] -= h * grad[i];
    elastic_drift(c, q, p, half);
    damp();
  }
  for (int i = 0; i < 3; ++i) s.q[i] = q[i], s.p[i] = p[i];
}

// 3s merged step to step (see pendulum_3s_merged): damp h between steps.
void elastic_3s_merged(Elastic& s, long n_steps, double h) {
  const ElasticConstants c(s);
  const double half = 0.5 * h;
  const double decay_half_m1 = std::expm1(-half * c.a), decay_m1 = std::expm1(-h * c.a);
  double q[3] = {s.q[0], s.q[1], s.q[2]}, p[3] = {s.p[0], s.p[1], s.p[2]}, grad[3];
  auto damp = [&](double factor_m1) {
    const double radial = factor_m1 * dot(q, p) * (1.0 / dot(q, q));
    for (int i = 0; i < 3; ++i) p[i] += radial * q[i];
  };
  auto inner = [&] {
    elastic_drift(c, q, p, half);
    elastic_gradient(c, q, grad);
    for (int i = 0; i < 3; ++i) p[i] -= h * grad[i];
    elastic_drift(c, q, p, half);
  };
  damp(decay_half_m1);
  for (long n = 0; n + 1 < n_steps; ++n) {
    inner();
    damp(decay_m1);
  }
  inner();
  damp(decay_half_m1);
  for (int i = 0; i < 3; ++i) s.q[i] = q[i], s.p[i] = p[i];
}

// 2s: drift h/2; exact kick+damp h: tangentially a plain kick, radially
// p_r <- e^{-h a} p_r - h phi1(-h a) g_r; drift h/2.
void elastic_2s(Elastic& s, long n_steps, double h) {
  const ElasticConstants c(s);
  const double half = 0.5 * h;
  const double x = -h * c.a;
  const double decay_m1 = std::expm1(x);
  const double kick_extra = h * (phi1(x) - 1.0);
  double q[3] = {s.q[0], s.q[1], s.q[2]}, p[3] = {s.p[0], s.p[1], s.p[2]}, grad[3];
  for (long n = 0; n < n_steps; ++n) {
    elastic_drift(c, q, p, half);
    elastic_gradient(c, q, grad);
    const double radial = (decay_m1 * dot(q, p) - kick_extra * dot(q, grad)) * (1.0 / dot(q, q));
    for (int i = 0; i < 3; ++i) p[i] += radial * q[i] - h * grad[i];
    elastic_drift(c, q, p, half);
  }
  for (int i = 0; i < 3; ++i) s.q[i] = q[i], s.p[i] = p[i];
}

// rks: drift h/2; Heun on p' = -grad V(q) - A p with q frozen; drift h/2.
void elastic_rks(Elastic& s, long n_steps, double h) {
  const ElasticConstants c(s);
  const double half = 0.5 * h;
  double q[3] = {s.q[0], s.q[1], s.q[2]}, p[3] = {s.p[0], s.p[1], s.p[2]}, grad[3];
  for (long n = 0; n < n_steps; ++n) {
    elastic_drift(c, q, p, half);
    elastic_gradient(c, q, grad);
    const double r2 = dot(q, q);
    double k0[3], k1[3], stage[3];
    const double rate0 = c.a * dot(q, p) / r2;
    for (int i = 0; i < 3; ++i) k0[i] = -(rate0 * q[i]);
    for (int i = 0; i < 3; ++i) stage[i] = (p[i] - h * grad[i]) + h * k0[i];
    const double rate1 = c.a * dot(q, stage) / r2;
    for (int i = 0; i < 3; ++i) k1[i] = -(rate1 * q[i]);
    for (int i = 0; i < 3; ++i) p[i] = ((p[i] - h * grad[i]) + half * k0[i]) + half * k1[i];
    elastic_drift(c, q, p, half);
  }
  for (int i = 0; i < 3; ++i) s.q[i] = q[i], s.p[i] = p[i];
}

// ---- Command line.

[[noreturn]] void usage(const std::string& why) {
  std::fprintf(stderr,
               "handwritten: %s\nusage: handwritten damped_pendulum|elastic_pendulum 3s|3s_merged|2s|rks N_STEPS "
               "[h=H] [repeats=R] [eps=E] [q=a,b,c] [p=a,b,c] [m=M] [k=K] [l=L] [g=x,y,z]\n",
               why.c_str());
  std::exit(2);
}

double number(const std::string& text, const std::string& what) {
  char* end = nullptr;
  const double x = std::strtod(text.c_str(), &end);
  if (text.empty() || *end != '\0') usage("bad number for " + what + ": '" + text + "'");
  return x;
}

std::vector<double> numbers(const std::string& text, const std::string& what) {
  std::vector<double> out;
  std::size_t start = 0;
  while (true) {
    const std::size_t comma = text.find(',', start);
    out.push_back(number(text.substr(start, comma - start), what));
    if (comma == std::string::npos) return out;
    start = comma + 1;
  }
}

void print_vector(const char* name, const double* x, int n) {
  std::printf("%s", name);
  for (int i = 0; i < n; ++i) std::printf(" %.17g", x[i]);
  std::printf("\n");
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 4) usage("need MODEL METHOD N_STEPS");
  const std::string model = argv[1], method = argv[2];
  const long n_steps = std::strtol(argv[3], nullptr, 10);
  if (n_steps < 1) usage("N_STEPS must be >= 1");
  const bool elastic = model == "elastic_pendulum";
  if (!elastic && model != "damped_pendulum") usage("unknown model '" + model + "'");
  if (method != "3s" && method != "3s_merged" && method != "2s" && method != "rks")
    usage("unknown method '" + method + "'");
  const int n = elastic ? 3 : 1;

  double h = 1e-3, eps = elastic ? 0.1 : 0.01, m = 1.0, k = 1.0, l = 1.0;
  long repeats = 5;
  std::vector<double> q0(n, 0.5), p0(n, 0.0), g = {0.0, 0.0, -1.0};
  for (int i = 4; i < argc; ++i) {
    const std::string arg = argv[i];
    const std::size_t eq = arg.find('=');
    if (eq == std::string::npos) usage("expected key=value, got '" + arg + "'");
    const std::string key = arg.substr(0, eq), value = arg.substr(eq + 1);
    if (key == "h") h = number(value, key);
    else if (key == "repeats") repeats = static_cast<long>(number(value, key));
    else if (key == "eps") eps = number(value, key);
    else if (key == "m") m = number(value, key);
    else if (key == "k") k = number(value, key);
    else if (key == "l") l = number(value, key);
    else if (key == "q") q0 = numbers(value, key);
    else if (key == "p") p0 = numbers(value, key);
    else if (key == "g") g = numbers(value, key);
    else usage("unknown option '" + key + "'");
  }
  if (static_cast<int>(q0.size()) != n || static_cast<int>(p0.size()) != n || g.size() != 3)
    usage("q and p need " + std::to_string(n) + " components, g needs 3");
  if (repeats < 1) repeats = 1;

  double best = INFINITY;
  double q[3] = {}, p[3] = {};
  for (long r = 0; r < repeats; ++r) {
    // Every repeat starts from the initial state read from argv, so the compiler
    // sees a fresh computation each time, and prints depend on the last one.
    Pendulum pendulum{eps, q0[0], p0[0]};
    Elastic spring{eps, m, k, l, {g[0], g[1], g[2]}, {}, {}};
    for (int i = 0; i < n && elastic; ++i) spring.q[i] = q0[i], spring.p[i] = p0[i];

    const auto start = std::chrono::steady_clock::now();
    if (!elastic) {
      if (method == "3s") pendulum_3s(pendulum, n_steps, h);
      else if (method == "3s_merged") pendulum_3s_merged(pendulum, n_steps, h);
      else if (method == "2s") pendulum_2s(pendulum, n_steps, h);
      else pendulum_rks(pendulum, n_steps, h);
    } else {
      if (method == "3s") elastic_3s(spring, n_steps, h);
      else if (method == "3s_merged") elastic_3s_merged(spring, n_steps, h);
      else if (method == "2s") elastic_2s(spring, n_steps, h);
      else elastic_rks(spring, n_steps, h);
    }
    const auto stop = std::chrono::steady_clock::now();
    best = std::min(best, std::chrono::duration<double>(stop - start).count());

    if (elastic) {
      for (int i = 0; i < 3; ++i) q[i] = spring.q[i], p[i] = spring.p[i];
    } else {
      q[0] = pendulum.q;
      p[0] = pendulum.p;
    }
  }
  std::printf("model %s\nmethod %s\nsteps %ld\nrepeats %ld\n", model.c_str(), method.c_str(), n_steps, repeats);
  std::printf("ns_per_step %.4f\n", best / static_cast<double>(n_steps) * 1e9);
  print_vector("q", q, n);
  print_vector("p", p, n);
  return 0;
}
