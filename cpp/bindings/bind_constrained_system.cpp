// Compiled systems with holonomic constraints (models/constrained_system.hpp): each (mass, damping) kind
// bound once, as for the free kinds (bind_system.hpp); the constraints are data.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>
#include <type_traits>

#include "bind_system.hpp"
#include "raydamp/constraints/least_work.hpp"
#include "raydamp/constraints/projected_dampers.hpp"
#include "raydamp/constraints/rattle.hpp"
#include "raydamp/models/constrained_system.hpp"

namespace raydamp::bindings {

namespace {

// The message of a run the constraint solve stopped (the step loop saw a state no longer finite).
std::string constraint_message(const ConstraintFailure& f, const py::dict& out) {
  const std::string at = out["failed_step"].is_none() ? std::string("")
                                                        : " at step " + py::str(out["failed_step"]).cast<std::string>();
  if (f.singular)
    return "constraints: G M^{-1} G^T is singular" + at + " (the constraints' gradients became dependent); the last "
           "state before it is saved";
  char buffer[160];
  std::snprintf(buffer, sizeof buffer, " did not converge%s: |g| = %.3g after %d Newton iterations, allowed %.3g",
                at.c_str(), f.residual, f.iterations, f.allowed);
  return "constraints[" + std::to_string(f.constraint) + "]" + buffer +
         "; the last state before it is saved (a smaller h, or a larger constraint_tol)";
}

// The multipliers at each saved row (constraints::multipliers), NaN where G M^{-1} G^T is singular.
template <class Model>
py::array_t<double> saved_multipliers(const Model& model, const py::dict& out, const Load* load) {
  const auto t = out["t"].cast<py::array_t<double, py::array::c_style | py::array::forcecast>>();
  const auto q = out["q"].cast<py::array_t<double, py::array::c_style | py::array::forcecast>>();
  const auto p = out["p"].cast<py::array_t<double, py::array::c_style | py::array::forcecast>>();
  const py::ssize_t rows = t.shape(0), n = model.constraints.n, k = model.constraints.k;
  py::array_t<double> lambda({rows, k});
  double* result = lambda.mutable_data();
  {
    py::gil_scoped_release released;
    Eigen::VectorXd qi(n), pi(n);
    for (py::ssize_t i = 0; i < rows; ++i) {
      qi = Eigen::Map<const Eigen::VectorXd>(q.data() + i * n, n);
      pi = Eigen::Map<const Eigen::VectorXd>(p.data() + i * n, n);
      if (!constraints::multipliers(model, qi, pi, t.data()[i], load, result + i * k))
        std::fill(result + i * k, result + (i + 1) * k, std::numeric_limits<double>::quiet_NaN());
    }
  }
  return lambda;
}

template <class Mass, class Damping>
void bind_constrained_kind(py::module_& m, const char* name) {
  using Model = ConstrainedSystem<Mass, Damping>;
  py::class_<Model> cls(m, name);
  cls.def(py::init([](int n, double eps, const Eigen::MatrixXd& mass, double damping_scalar,
                      const Eigen::MatrixXd& damping_matrix, const FunctionAddresses& functions, int n_momenta,
                      py::object /*keep_alive*/, int k, const FunctionAddresses& constraint_functions,
                      std::vector<int> rows, std::vector<int> cols, double tol, int max_iterations,
                      const std::vector<double>& damper_coefficients) {
            if (mass.rows() != n || mass.cols() != n) throw std::invalid_argument("mass: expected an n x n matrix");
            if (functions.size() != 14) throw std::invalid_argument("functions: expected 7 (function, data) pairs");
            if (constraint_functions.size() != 6)
              throw std::invalid_argument("constraint_functions: expected 3 (function, data) pairs");
            const SystemFunctions f{compiled(functions, 0), compiled(functions, 1), compiled(functions, 2),
                                    compiled(functions, 4), CompiledFunction{}};
            CompiledSystem<Mass, Damping> base(
                n, eps, make_mass<Mass>(mass),
                // Dashpots by their gradients (functions[3]): the projected flow needs them at every q.
                make_damping<Damping>(mass, eps, damping_scalar, damping_matrix, damper_coefficients,
                                      compiled(functions, 3), std::numeric_limits<double>::quiet_NaN(),
                                      CompiledFunction{}),
                f, n_momenta);
            constraints::Dashpots dashpots;
            if constexpr (std::is_same_v<Damping, DamperDamping>)
              dashpots = constraints::Dashpots(mass, eps, damper_coefficients, compiled(functions, 3));
            return Model(std::move(base),
                         ConstraintSet(k, n, compiled(constraint_functions, 0), compiled(constraint_functions, 1),
                                       compiled(constraint_functions, 2), std::move(rows), std::move(cols), tol,
                                       max_iterations),
                         std::move(dashpots));
          }),
          py::arg("n"), py::arg("eps"), py::arg("mass"), py::arg("damping_scalar"), py::arg("damping_matrix"),
          py::arg("functions"), py::arg("n_momenta"), py::arg("keep_alive"), py::arg("k"),
          py::arg("constraint_functions"), py::arg("rows"), py::arg("cols"), py::arg("tol"),
          py::arg("max_iterations"), py::arg("damper_coefficients") = std::vector<double>{},
          // The compiled code lives as long as the Python object that owns it.
          py::keep_alive<1, 9>());
  add_model_functions<Model>(cls);
  // Members run as single runs (ensemble/driver.hpp); each worker thread's solve scratch is made ready for
  // the model by its first constrained flow (constraint_work(set)).
  def_integrate_ensemble<Model>(m);
  // run() with the constraint solve's scratch made ready first and read after: the residuals the run
  // reached, and the constraint that stopped it, if one did.
  cls.def(
      "integrate",
      [](const Model& model, const std::string& method, const std::string& tableau, const std::string& composition,
         const Eigen::VectorXd& q0, const Eigen::VectorXd& p0, double h, long n_steps, double h_last, long save_every,
         bool track_work, py::object progress, CancelToken* cancel, const std::vector<int>& save_dofs,
         const BoundLoad* load, double temperature, std::uint64_t seed, std::uint64_t stream, double divergence,
         const EventSet* events, bool dense, const EnvelopeSpec* envelope) {
        ConstraintWork& w = constraint_work();
        w.prepare(model.constraints);
        w.track = true;
        py::dict out = run<Model>(model, method, tableau, composition, q0, p0, h, n_steps, h_last, save_every,
                                  track_work, progress, cancel, save_dofs, load, temperature, seed, stream,
                                  divergence, events, dense, envelope);
        w.track = false;
        if (w.failure.constraint >= 0) {
          if (out["status"].cast<std::string>() == status_name(Status::non_finite)) {
            out["status"] = status_name(Status::constraint_failed);
            out["message"] = constraint_message(w.failure, out);
            out["failed_constraint"] = w.failure.constraint;
          }
        }
        out["constraint_residual"] = w.max_residual;
        out["constraint_velocity_residual"] = w.max_velocity_residual;
        out["constraint_solves"] = py::make_tuple(w.drifts, w.iterations, w.refreshes, w.factorisations);
        if (save_dofs.empty()) out["multipliers"] = saved_multipliers(model, out, load_of(load));
        return out;
      },
      py::arg("method"), py::arg("tableau"), py::arg("composition"), py::arg("q0"), py::arg("p0"), py::arg("h"),
      py::arg("n_steps"), py::arg("h_last"), py::arg("save_every"), py::arg("track_work"), py::arg("progress"),
      py::arg("cancel").none(true), py::arg("save_dofs") = std::vector<int>{},
      py::arg("load").none(true) = py::none(), py::arg("temperature") = 0.0, py::arg("seed") = 0,
      py::arg("stream") = 0, py::arg("divergence") = kDefaultDivergence, py::arg("events").none(true) = py::none(),
      py::arg("dense") = false, py::arg("envelope").none(true) = py::none());
  // One constrained sub-flow or projection at a time, for tests and the initial checks.
  cls.def("constrained_flow", [](const Model& model, const std::string& flow, const Eigen::VectorXd& q,
                                 const Eigen::VectorXd& p, double t) {
    State<Eigen::Dynamic> z{q, p};
    WorkspaceFor<Model> ws(model.size(), 1);
    ConstraintWork& w = constraint_work();
    w.prepare(model.constraints);
    const ButcherTableau& tab = builtin_tableau("euler");
    if (flow == "drift") constraints::flow<Flow::drift>(model, tab, z, t, ws);
    else if (flow == "kick") constraints::flow<Flow::kick>(model, tab, z, t, ws);
    else if (flow == "damp") constraints::flow<Flow::damp>(model, tab, z, t, ws);
    else if (flow == "kick_damp") constraints::flow<Flow::kick_damp>(model, tab, z, t, ws);
    else if (flow == "project") constraints::project(model, z, w);
    else throw std::invalid_argument("flow: unknown sub-flow '" + flow + "' (known: drift, kick, damp, kick_damp, project)");
    return py::make_tuple(z.q, z.p);
  });
  // The floor of a constrained step's cost beside the free step's (benchmarks/bench_constraints.py).
  cls.def(
      "least_constraint_work_ns",
      [](const Model& model, const Eigen::VectorXd& q, const Eigen::VectorXd& p, double h, long steps) {
        if (q.size() != model.constraints.n || p.size() != model.constraints.n)
          throw std::invalid_argument("q, p: expected " + std::to_string(model.constraints.n) + " entries");
        if (!(h > 0.0) || steps < 1) throw std::invalid_argument("h, steps: must be > 0");
        py::gil_scoped_release released;
        return constraints::least_work_ns(model.constraints, q, p, h, steps);
      },
      py::arg("q"), py::arg("p"), py::arg("h"), py::arg("steps"));
}

}  // namespace

void bind_constrained_system(py::module_& m) {
  bind_constrained_kind<ScalarMass, IsotropicDamping>(m, "ConstrainedSystem_scalar_isotropic");
  bind_constrained_kind<ScalarMass, ConstantDamping>(m, "ConstrainedSystem_scalar_constant");
  bind_constrained_kind<DenseMass, IsotropicDamping>(m, "ConstrainedSystem_dense_isotropic");
  bind_constrained_kind<DenseMass, ConstantDamping>(m, "ConstrainedSystem_dense_constant");
  bind_constrained_kind<ScalarMass, DamperDamping>(m, "ConstrainedSystem_scalar_dampers");
  bind_constrained_kind<DenseMass, DamperDamping>(m, "ConstrainedSystem_dense_dampers");
}

}  // namespace raydamp::bindings
