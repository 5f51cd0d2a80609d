// The run() every model kind binds as its class's integrate method: validates nothing Python
// has not (Python owns argument names), runs the C++ step loop with the GIL
// released and hands the saved points to NumPy without a copy.
#pragma once

#include <pybind11/eigen.h>
#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <atomic>
#include <memory>
#include <type_traits>

#include "bindings.hpp"
#include "load_binding.hpp"
#include "raydamp/ensemble/driver.hpp"
#include "raydamp/implicit/linear_implicit_step.hpp"
#include "raydamp/raydamp.hpp"

namespace raydamp::bindings {

namespace py = pybind11;

struct CancelToken {
  std::atomic<bool> flag{false};
};

// A NumPy array that owns the vector's buffer.
inline py::array_t<double> to_numpy(std::vector<double>&& data, std::vector<py::ssize_t> shape) {
  auto* owned = new std::vector<double>(std::move(data));
  py::capsule owner(owned, [](void* p) { delete static_cast<std::vector<double>*>(p); });
  if (owned->empty()) return py::array_t<double>(shape);
  return py::array_t<double>(shape, owned->data(), owner);
}

// A run's events (events/types.hpp): event index, direction, t, and (q, p) of every coordinate there.
inline py::dict events_dict(EventLog&& log) {
  const py::ssize_t k = log.size();
  py::dict d;
  d["event"] = py::array_t<int>(k, log.event.data());
  d["direction"] = py::array_t<int>(k, log.direction.data());
  d["t"] = to_numpy(std::move(log.t), {k});
  d["q"] = to_numpy(std::move(log.q), {k, log.n});
  d["p"] = to_numpy(std::move(log.p), {k, log.n});
  return d;
}

// A run's envelope (record/envelope.hpp): each peak asked for, as {name: (peak, time)}.
inline py::dict envelope_dict(EnvelopeRecord&& rec) {
  py::dict d;
  for (int k = 0; k < kPeaks; ++k) {
    if (rec.peak[k].empty()) continue;
    const py::ssize_t size = static_cast<py::ssize_t>(rec.peak[k].size());
    d[kPeakNames[k]] = py::make_tuple(to_numpy(std::move(rec.peak[k]), {size}), to_numpy(std::move(rec.time[k]), {size}));
  }
  d["collapse_spring"] = rec.collapse_spring;
  return d;
}

// What dense output interpolates: t, q, p, v = M^{-1} p and f = pdot at every step end.
inline py::dict dense_dict(DenseRecord&& rec) {
  const py::ssize_t k = rec.rows();
  py::dict d;
  d["t"] = to_numpy(std::move(rec.t), {k});
  d["q"] = to_numpy(std::move(rec.q), {k, rec.n});
  d["p"] = to_numpy(std::move(rec.p), {k, rec.n});
  d["v"] = to_numpy(std::move(rec.v), {k, rec.n});
  d["f"] = to_numpy(std::move(rec.f), {k, rec.n});
  return d;
}

template <class Model>
py::dict run(const Model& model, const std::string& method, const std::string& tableau,
             const std::string& composition, const typename Model::Vec& q0, const typename Model::Vec& p0, double h, long n_steps, double h_last,
             long save_every, bool track_work, py::object progress, CancelToken* cancel,
             const std::vector<int>& save_dofs, const BoundLoad* load, double temperature, std::uint64_t seed,
             std::uint64_t stream, double divergence, const EventSet* events, bool dense,
             const EnvelopeSpec* envelope) {
  const MethodEntry& entry = method_entry(method);
  require_applicable(entry, model);
  const ButcherTableau& tab = resolve_tableau(entry, tableau);
  const Composition& comp = resolve_composition(entry, tab, composition);
  RunSpec spec{h, n_steps, h_last, save_every, track_work};
  spec.save_dofs = save_dofs;
  spec.load = load_of(load);
  spec.temperature = temperature;
  spec.seed = seed;
  spec.stream = stream;
  spec.divergence = divergence;
  spec.events = events;
  spec.dense = dense;
  spec.envelope = envelope;
  Control control;
  if (cancel) control.cancel = &cancel->flag;
  if (!progress.is_none())
    control.progress = [progress](long done, long total) {
      py::gil_scoped_acquire gil;
      progress(done, total);
    };
  RunResult r;
  {
    py::gil_scoped_release release;
    r = with_method_for<Model>(method, [&](auto m) {
      return integrate_model<decltype(m)>(model, tab, comp, State<Model::dim>{q0, p0}, spec, control);
    });
  }
  Trajectory& tr = r.trajectory;
  const py::ssize_t rows = tr.rows();
  py::dict out;
  out["status"] = status_name(r.status);
  out["steps"] = r.steps;
  out["failed_step"] = r.failed_step < 0 ? py::none() : py::cast(r.failed_step);
  out["message"] = r.message;
  out["max_momentum_drift"] = r.max_momentum_drift;
  out["tableau"] = tab.name();
  out["t"] = to_numpy(std::move(tr.t), {rows});
  out["q"] = to_numpy(std::move(tr.q), {rows, tr.n});
  out["p"] = to_numpy(std::move(tr.p), {rows, tr.n});
  out["energy"] = to_numpy(std::move(tr.energy), {rows});
  out["momentum"] = to_numpy(std::move(tr.momentum), {rows, tr.n_momenta});
  out["work"] = track_work ? py::object(to_numpy(std::move(tr.work), {rows})) : py::none();
  out["load_work"] = track_work && spec.load ? py::object(to_numpy(std::move(tr.load_work), {rows})) : py::none();
  out["spring_work"] = track_work && tr.n_springs > 0
                           ? py::object(to_numpy(std::move(tr.spring_work), {rows, tr.n_springs}))
                           : py::none();
  out["spring_force"] = tr.n_springs > 0 ? py::object(to_numpy(std::move(tr.spring_force), {rows, tr.n_springs}))
                                         : py::none();
  out["spring_deformation"] =
      tr.n_springs > 0 ? py::object(to_numpy(std::move(tr.spring_deformation), {rows, tr.n_springs})) : py::none();
  if (events) out["events"] = events_dict(std::move(r.events));
  if (dense) out["dense"] = dense_dict(std::move(r.dense));
  if (envelope) out["envelope"] = envelope_dict(std::move(r.envelope));
  return out;
}

// Registers run<Model> as the method `integrate` of Model's class: one function per
// kind, which a call reaches with no overload resolution. (As the overloads of one
// module function, a call was offered to every kind in turn, twice, and pybind11 3
// looks for a foreign loader of each kind that does not match, raising and clearing
// an AttributeError each time: 20 of the 25 us of a 10-step call on this machine.)
template <class Model>
void def_integrate(py::module_&) {
  auto cls = py::reinterpret_borrow<py::class_<Model>>(py::type::of<Model>());
  cls.def("integrate", &run<Model>, py::arg("method"), py::arg("tableau"), py::arg("composition"), py::arg("q0"),
          py::arg("p0"), py::arg("h"), py::arg("n_steps"), py::arg("h_last"), py::arg("save_every"),
          py::arg("track_work"), py::arg("progress"), py::arg("cancel").none(true),
          py::arg("save_dofs") = std::vector<int>{}, py::arg("load").none(true) = py::none(),
          py::arg("temperature") = 0.0, py::arg("seed") = 0, py::arg("stream") = 0,
          py::arg("divergence") = kDefaultDivergence, py::arg("events").none(true) = py::none(),
          py::arg("dense") = false, py::arg("envelope").none(true) = py::none());
}

}  // namespace raydamp::bindings
