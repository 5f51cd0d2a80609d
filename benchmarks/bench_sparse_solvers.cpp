// Which sparse solver the implicit methods (implicit/linear_implicit_step.hpp) use: the
// matrix of a midpoint step, S = M + (h/2) C + (h^2/4) K, factorised once and solved
// once per step, timed for raydamp's SparseLDLT (up-looking LDL^T, AMD), Eigen's
// SimplicialLDLT and CHOLMOD (supernodal and simplicial; cholmod_solve2 with reused
// buffers, so a solve allocates nothing), on the benchmark structures of
// bench_vs_opensees.py (a shear-building chain, a 2-D cantilever of Euler-Bernoulli
// beam elements) and, given as Matrix Market files, any other (the 2-D plate of
// tests/fe_plate.py: bench_vs_opensees.py --export-plate DIR writes it).
//
// Built by hand (it links CHOLMOD, which the module does not need):
//   g++ -O3 -std=c++17 -DNDEBUG -I cpp/include -I /usr/include/eigen3 -I /usr/include/suitesparse \
//       benchmarks/bench_sparse_solvers.cpp -lcholmod -o build/bench_sparse_solvers
//   build/bench_sparse_solvers [M.mtx K.mtx]...
#include <Eigen/CholmodSupport>
#include <Eigen/SparseCholesky>
#include <chrono>
#include <cmath>
#include <complex>
#include <cstdio>
#include <string>
#include <unsupported/Eigen/SparseExtra>
#include <vector>

#include "raydamp/linalg/sparse_ldlt.hpp"

using Sparse = Eigen::SparseMatrix<double, Eigen::ColMajor, int>;
using Clock = std::chrono::steady_clock;

namespace {

double seconds_since(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

// A shear building of n storeys: unit masses, unit springs, fixed base.
std::pair<Sparse, Sparse> chain(int n) {
  std::vector<Eigen::Triplet<double>> k, m;
  for (int i = 0; i < n; ++i) {
    m.emplace_back(i, i, 1.0);
    k.emplace_back(i, i, i + 1 < n ? 2.0 : 1.0);
    if (i + 1 < n) {
      k.emplace_back(i, i + 1, -1.0);
      k.emplace_back(i + 1, i, -1.0);
    }
  }
  Sparse km(n, n), mm(n, n);
  km.setFromTriplets(k.begin(), k.end());
  mm.setFromTriplets(m.begin(), m.end());
  return {mm, km};
}

// A cantilever of `elements` 2-D frame elements (u, w, theta per node), consistent mass.
std::pair<Sparse, Sparse> beam(int elements) {
  const double length = 1.0 / elements, ea = 0.05, ei = 0.05 * 0.05 * 0.05 / 12.0, rho_a = 0.05;
  const double l = length, l2 = l * l, l3 = l2 * l, mm = rho_a * l / 420.0;
  const double ke[6][6] = {{ea / l, 0, 0, -ea / l, 0, 0},
                           {0, 12 * ei / l3, 6 * ei / l2, 0, -12 * ei / l3, 6 * ei / l2},
                           {0, 6 * ei / l2, 4 * ei / l, 0, -6 * ei / l2, 2 * ei / l},
                           {-ea / l, 0, 0, ea / l, 0, 0},
                           {0, -12 * ei / l3, -6 * ei / l2, 0, 12 * ei / l3, -6 * ei / l2},
                           {0, 6 * ei / l2, 2 * ei / l, 0, -6 * ei / l2, 4 * ei / l}};
  const double me[6][6] = {{140 * mm, 0, 0, 70 * mm, 0, 0},
                           {0, 156 * mm, 22 * l * mm, 0, 54 * mm, -13 * l * mm},
                           {0, 22 * l * mm, 4 * l2 * mm, 0, 13 * l * mm, -3 * l2 * mm},
                           {70 * mm, 0, 0, 140 * mm, 0, 0},
                           {0, 54 * mm, 13 * l * mm, 0, 156 * mm, -22 * l * mm},
                           {0, -13 * l * mm, -3 * l2 * mm, 0, -22 * l * mm, 4 * l2 * mm}};
  const int n = 3 * elements;
  std::vector<Eigen::Triplet<double>> k, m;
  for (int e = 0; e < elements; ++e)
    for (int i = 0; i < 6; ++i)
      for (int j = 0; j < 6; ++j) {
        const int a = 3 * (e - 1) + i, b = 3 * (e - 1) + j;  // node 0 clamped
        if (a < 0 || b < 0) continue;
        if (ke[i][j] != 0) k.emplace_back(a, b, ke[i][j]);
        if (me[i][j] != 0) m.emplace_back(a, b, me[i][j]);
      }
  Sparse km(n, n), mass(n, n);
  km.setFromTriplets(k.begin(), k.end());
  mass.setFromTriplets(m.begin(), m.end());
  return {mass, km};
}

// Best of `repeats` of f, in seconds.
template <class F>
double best(int repeats, F f) {
  double out = 1e300;
  for (int r = 0; r < repeats; ++r) {
    const auto start = Clock::now();
    f();
    out = std::min(out, seconds_since(start));
  }
  return out;
}

void measure(const std::string& name, const Sparse& m, const Sparse& k) {
  const int n = static_cast<int>(m.rows());
  // 2% damping-like coefficients and h = 1e-3 of the structure's time scale: only the
  // pattern and the conditioning matter for the timing.
  const double alpha = 1e-3, beta = 1e-4, h = 1e-2;
  const Sparse s = (1.0 + 0.5 * h * alpha) * m + (0.5 * h * beta + 0.25 * h * h) * k;
  const Eigen::VectorXd b = Eigen::VectorXd::LinSpaced(n, -1.0, 1.0).array().sin();
  const int solves = std::max(20, static_cast<int>(2e7 / std::max<Eigen::Index>(1, s.nonZeros())));
  Eigen::VectorXd x(n), work(n);

  // raydamp::SparseLDLT: analysis + numeric factorisation, then solves.
  double t_factor_ours = 0.0, t_solve_ours = 0.0;
  long nnz_ours = 0;
  {
    t_factor_ours = best(3, [&] {
      auto pattern = std::make_shared<const raydamp::SparsePattern>(Sparse(m.cwiseAbs() + k.cwiseAbs()));
      raydamp::SparseLDLT<double> f(pattern, s, "S");
      nnz_ours = f.nonzeros();
    });
    auto pattern = std::make_shared<const raydamp::SparsePattern>(Sparse(m.cwiseAbs() + k.cwiseAbs()));
    raydamp::SparseLDLT<double> f(pattern, s, "S");
    t_solve_ours = best(3, [&] {
                     for (int i = 0; i < solves; ++i) f.solve(b, x, work);
                   }) / solves;
  }
  const double residual_ours = (s * x - b).norm() / b.norm();

  // The complex symmetric factor of gauss4 (for the record: same pattern, complex arithmetic).
  double t_factor_complex = 0.0, t_solve_complex = 0.0;
  {
    using C = std::complex<double>;
    const C c = C(h, 0.0) / C(3.0, std::sqrt(3.0));
    const Eigen::SparseMatrix<C, Eigen::ColMajor, int> sc =
        m.cast<C>() * (C(1.0) + c * alpha) + k.cast<C>() * (c * beta + c * c);
    auto pattern = std::make_shared<const raydamp::SparsePattern>(Sparse(m.cwiseAbs() + k.cwiseAbs()));
    t_factor_complex = best(3, [&] {
      auto analysed = std::make_shared<const raydamp::SparsePattern>(Sparse(m.cwiseAbs() + k.cwiseAbs()));
      raydamp::SparseLDLT<C> f(analysed, sc, "S");
    });
    raydamp::SparseLDLT<C> f(pattern, sc, "S");
    Eigen::VectorXcd bc = b.cast<C>(), xc(n), wc(n);
    t_solve_complex = best(3, [&] {
                        for (int i = 0; i < solves; ++i) f.solve(bc, xc, wc);
                      }) / solves;
  }

  // Eigen::SimplicialLDLT (its solve allocates its result).
  double t_factor_eigen = 0.0, t_solve_eigen = 0.0;
  {
    t_factor_eigen = best(3, [&] { Eigen::SimplicialLDLT<Sparse> f(s); });
    Eigen::SimplicialLDLT<Sparse> f(s);
    t_solve_eigen = best(3, [&] {
                      for (int i = 0; i < solves; ++i) x = f.solve(b);
                    }) / solves;
  }

  // CHOLMOD, supernodal and simplicial: cholmod_analyze + cholmod_factorize, cholmod_solve2.
  auto cholmod = [&](int supernodal, double& t_factor, double& t_solve, long& nnz_factor) {
    cholmod_common common;
    cholmod_start(&common);
    common.supernodal = supernodal;
    common.final_ll = 0;
    Sparse upper = s.triangularView<Eigen::Upper>();
    upper.makeCompressed();
    cholmod_sparse a = Eigen::viewAsCholmod(upper);
    a.stype = 1;
    cholmod_factor* factor = nullptr;
    t_factor = best(3, [&] {
      if (factor) cholmod_free_factor(&factor, &common);
      factor = cholmod_analyze(&a, &common);
      cholmod_factorize(&a, factor, &common);
    });
    nnz_factor = static_cast<long>(common.lnz);
    cholmod_dense* rhs = cholmod_allocate_dense(n, 1, n, CHOLMOD_REAL, &common);
    std::copy(b.data(), b.data() + n, static_cast<double*>(rhs->x));
    cholmod_dense *solution = nullptr, *y = nullptr, *e = nullptr;
    t_solve = best(3, [&] {
                for (int i = 0; i < solves; ++i)
                  cholmod_solve2(CHOLMOD_A, factor, rhs, nullptr, &solution, nullptr, &y, &e, &common);
              }) / solves;
    cholmod_free_dense(&solution, &common);
    cholmod_free_dense(&y, &common);
    cholmod_free_dense(&e, &common);
    cholmod_free_dense(&rhs, &common);
    cholmod_free_factor(&factor, &common);
    cholmod_finish(&common);
  };
  double t_factor_super = 0, t_solve_super = 0, t_factor_simp = 0, t_solve_simp = 0;
  long nnz_super = 0, nnz_simp = 0;
  cholmod(CHOLMOD_SUPERNODAL, t_factor_super, t_solve_super, nnz_super);
  cholmod(CHOLMOD_SIMPLICIAL, t_factor_simp, t_solve_simp, nnz_simp);

  std::printf("%-22s %8d %9ld %9ld | %8.2f %8.1f | %8.2f %8.1f | %8.2f %8.1f | %8.2f %8.1f | %8.2f %8.1f | %7.1e\n",
              name.c_str(), n, nnz_ours, nnz_simp, 1e3 * t_factor_ours, 1e6 * t_solve_ours, 1e3 * t_factor_eigen,
              1e6 * t_solve_eigen, 1e3 * t_factor_super, 1e6 * t_solve_super, 1e3 * t_factor_simp,
              1e6 * t_solve_simp, 1e3 * t_factor_complex, 1e6 * t_solve_complex, residual_ours);
}

}  // namespace

int main(int argc, char** argv) {
  std::printf("factor: ms (analysis + numeric, best of 3); solve: us per solve (best of 3 runs of many)\n");
  std::printf("%-22s %8s %9s %9s | %17s | %17s | %17s | %17s | %17s |\n", "structure", "n", "nnz(L)", "CHOLMOD",
              "raydamp LDL^T", "Eigen Simplicial", "CHOLMOD supernodal", "CHOLMOD simplicial", "ours, complex");
  std::printf("%-22s %8s %9s %9s | %8s %8s | %8s %8s | %8s %8s | %8s %8s | %8s %8s | %7s\n", "", "", "", "", "factor",
              "solve", "factor", "solve", "factor", "solve", "factor", "solve", "factor", "solve", "resid");
  for (int n : {200, 2000, 20000}) {
    auto [m, k] = chain(n);
    measure("chain", m, k);
  }
  for (int elements : {67, 667, 6667}) {
    auto [m, k] = beam(elements);
    measure("cantilever beam", m, k);
  }
  for (int i = 1; i + 1 < argc; i += 2) {
    Sparse m, k;
    if (!Eigen::loadMarket(m, argv[i]) || !Eigen::loadMarket(k, argv[i + 1])) {
      std::printf("cannot read %s or %s\n", argv[i], argv[i + 1]);
      return 1;
    }
    // (Files in the "general" format: both triangles stored.)
    measure(argv[i], m, k);
  }
  return 0;
}
