// The run_ensemble() every model kind binds as its class's integrate_ensemble: members x
// dof initial states, per-member models, one call, the members spread over threads
// with the GIL released (raydamp/ensemble/driver.hpp). Saved points land in arrays
// (member, row, ...) on the run's save grid; each worker copies its member's rows
// there as soon as the member ends.
#pragma once

#include <algorithm>
#include <limits>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "run.hpp"
#include "raydamp/ensemble/driver.hpp"
#include "raydamp/errors.hpp"

namespace raydamp::bindings {

using Rows = py::array_t<double, py::array::c_style | py::array::forcecast>;

// The places of the per-member parameters `names` ("eps", "g[1]") in Model's flat
// parameter values (models/parameters.hpp), found once before the member loop. Kinds
// without a parameter table (a System: Python builds one model per distinct parameter
// set; a Chain, a LinearStructure) take none.
template <class Model>
std::vector<int> member_value_slots(const std::vector<std::string>& names) {
  std::vector<int> slots;
  if constexpr (has_parameter_table<Model>::value) {
    for (const std::string& name : names) slots.push_back(resolve_value<Model>(name));
  } else if (!names.empty()) {
    throw std::invalid_argument("parameters: this model kind takes no per-member parameters");
  }
  return slots;
}

// A member's model: `base` with the values at `slots` set to `values`, built in C++ so
// that an ensemble over, say, eps costs no Python per member.
template <class Model>
Model with_parameters(const Model& base, const std::vector<int>& slots, const double* values) {
  if constexpr (has_parameter_table<Model>::value) {
    typename Model::Values all = base.values;
    for (std::size_t k = 0; k < slots.size(); ++k) all[slots[k]] = values[k];
    return Model(all);
  } else {
    return base;
  }
}

// The members' events as one table in member order: member, event, direction, t, q, p.
inline py::dict ensemble_events(std::vector<EventLog>&& logs, int n) {
  EventLog all;
  all.n = n;
  std::vector<long> member;
  for (std::size_t i = 0; i < logs.size(); ++i) {
    EventLog& log = logs[i];
    member.insert(member.end(), log.t.size(), static_cast<long>(i));
    all.event.insert(all.event.end(), log.event.begin(), log.event.end());
    all.direction.insert(all.direction.end(), log.direction.begin(), log.direction.end());
    all.t.insert(all.t.end(), log.t.begin(), log.t.end());
    all.q.insert(all.q.end(), log.q.begin(), log.q.end());
    all.p.insert(all.p.end(), log.p.begin(), log.p.end());
    log = EventLog{};
  }
  py::dict d = events_dict(std::move(all));
  d["member"] = py::array_t<long>(static_cast<py::ssize_t>(member.size()), member.data());
  return d;
}

// The members' envelopes as arrays (member, size) per peak, NaN for a member that recorded none (refused
// before its first step), and each member's collapsed spring (core order) or -1.
inline py::dict ensemble_envelopes(const std::vector<EnvelopeRecord>& records) {
  const py::ssize_t members = static_cast<py::ssize_t>(records.size());
  py::dict d;
  for (int k = 0; k < kPeaks; ++k) {
    std::size_t size = 0;
    for (const EnvelopeRecord& r : records) size = std::max(size, r.peak[k].size());
    if (size == 0) continue;
    py::array_t<double> peak({members, static_cast<py::ssize_t>(size)}), time({members, static_cast<py::ssize_t>(size)});
    std::fill(peak.mutable_data(), peak.mutable_data() + peak.size(), std::numeric_limits<double>::quiet_NaN());
    std::fill(time.mutable_data(), time.mutable_data() + time.size(), std::numeric_limits<double>::quiet_NaN());
    for (py::ssize_t i = 0; i < members; ++i) {
      const EnvelopeRecord& r = records[i];
      std::copy(r.peak[k].begin(), r.peak[k].end(), peak.mutable_data() + i * size);
      std::copy(r.time[k].begin(), r.time[k].end(), time.mutable_data() + i * size);
    }
    d[kPeakNames[k]] = py::make_tuple(peak, time);
  }
  py::array_t<long> collapsed(members);
  for (py::ssize_t i = 0; i < members; ++i) collapsed.mutable_data()[i] = records[i].collapse_spring;
  d["collapse_spring"] = collapsed;
  return d;
}

template <class Model>
py::dict run_ensemble(const std::vector<const Model*>& models, py::array_t<long, py::array::c_style | py::array::forcecast> model_index,
                      const std::vector<std::string>& names, Rows values, const std::string& method,
                      const std::string& tableau, const std::string& composition, Rows q0, Rows p0, double h,
                      long n_steps, double h_last, long save_every, int threads, py::object progress,
                      CancelToken* cancel, bool vector_sine, const std::vector<const BoundLoad*>& loads,
                      py::array_t<long, py::array::c_style | py::array::forcecast> load_index, double temperature,
                      std::uint64_t seed, std::uint64_t first_stream, const EventSet* events,
                      const EnvelopeSpec* envelope, bool dense) {
  if (q0.ndim() != 2 || q0.shape(0) < 1) throw std::invalid_argument("q0: expected an array of shape (members, n), members >= 1");
  const long members = static_cast<long>(q0.shape(0));
  if (models.empty()) throw std::invalid_argument("models: empty");
  const int n = models.front()->size();
  if (q0.ndim() != 2 || p0.ndim() != 2 || q0.shape(1) != n || p0.shape(1) != n || p0.shape(0) != members)
    throw std::invalid_argument("q0, p0: expected two arrays of shape (members, " + std::to_string(n) + ")");
  if (model_index.ndim() != 1 || model_index.shape(0) != members)
    throw std::invalid_argument("model_index: expected one index per member");
  if (values.ndim() != 2 || values.shape(0) != members || values.shape(1) != static_cast<py::ssize_t>(names.size()))
    throw std::invalid_argument("values: expected an array of shape (members, len(names))");
  const MethodEntry& entry = method_entry(method);
  const ButcherTableau& tab = resolve_tableau(entry, tableau);
  const Composition& comp = resolve_composition(entry, tab, composition);
  RunSpec spec{h, n_steps, h_last, save_every, false};
  spec.temperature = temperature;
  spec.seed = seed;
  spec.events = events;
  spec.envelope = envelope;
  spec.dense = dense;
  std::vector<EventLog> member_events(events ? members : 0);
  std::vector<DenseRecord> member_dense(dense ? members : 0);
  std::vector<EnvelopeRecord> member_envelopes(envelope ? members : 0);  // each worker fills its members' slots
  // Each member's load: loads[load_index[i]] (none without loads).
  std::vector<const Load*> member_load(members, nullptr);
  if (!loads.empty()) {
    if (load_index.ndim() != 1 || load_index.shape(0) != members)
      throw std::invalid_argument("load_index: expected one index per member");
    for (long i = 0; i < members; ++i) {
      const long j = load_index.data()[i];
      if (j < 0 || j >= static_cast<long>(loads.size()))
        throw std::invalid_argument("load_index: out of range at member " + std::to_string(i));
      member_load[i] = load_of(loads[j]);
    }
  }

  // Every member's model, checked here, before any thread starts.
  const std::vector<int> slots = member_value_slots<Model>(names);
  const long* index = model_index.data();
  std::vector<Model> built;
  std::vector<const Model*> member_model(members);
  if (!names.empty()) built.reserve(members);
  for (long i = 0; i < members; ++i) {
    if (index[i] < 0 || index[i] >= static_cast<long>(models.size()))
      throw std::invalid_argument("model_index: out of range at member " + std::to_string(i));
    const Model* model = models[index[i]];
    if (model->size() != n) throw std::invalid_argument("models: every member needs the same dimension");
    if (!names.empty()) {
      try {
        built.push_back(with_parameters(*model, slots, values.data(i, 0)));
      } catch (const std::invalid_argument& e) {
        rethrow_prefixed("member " + std::to_string(i) + ": parameters.", e);
      }
      model = &built.back();
    }
    try {
      require_applicable(entry, *model);
    } catch (const std::invalid_argument& e) {
      rethrow_prefixed("member " + std::to_string(i) + ": ", e);
    }
    member_model[i] = model;
  }

  const std::vector<double> grid = save_grid(h, n_steps, h_last, save_every);  // the rows a completed run saves
  const py::ssize_t R = static_cast<py::ssize_t>(grid.size());
  const int m = momentum_count(*member_model.front());
  const double nan = std::numeric_limits<double>::quiet_NaN();
  auto filled = [nan](std::vector<py::ssize_t> shape) {
    py::array_t<double> a(shape);
    std::fill(a.mutable_data(), a.mutable_data() + a.size(), nan);
    return a;
  };
  py::array_t<double> q = filled({members, R, n}), p = filled({members, R, n}), e = filled({members, R}),
                      J = filled({members, R, m}), q_final = filled({members, n}), p_final = filled({members, n}),
                      t_final = filled({members}), e_final = filled({members}), J_final = filled({members, m}),
                      drift = filled({members});
  // A structure's springs, as a single run records them: sigma_s and d_s per saved row, core order.
  py::ssize_t S = 0;
  if constexpr (has_materials_v<Model>) S = static_cast<py::ssize_t>(member_model.front()->springs.size());
  py::array_t<double> sf = filled({members, R, S}), sdef = filled({members, R, S}), sf_final = filled({members, S}),
                      sdef_final = filled({members, S});
  double *sfd = sf.mutable_data(), *sdd = sdef.mutable_data(), *sffd = sf_final.mutable_data(),
         *sdfd = sdef_final.mutable_data();
  py::array_t<long> rows(members), steps(members), failed(members);
  std::vector<std::string> status(members), message(members);
  double *qd = q.mutable_data(), *pd = p.mutable_data(), *ed = e.mutable_data(), *Jd = J.mutable_data(),
         *qf = q_final.mutable_data(), *pf = p_final.mutable_data(), *tf = t_final.mutable_data(),
         *ef = e_final.mutable_data(), *Jf = J_final.mutable_data(), *dd = drift.mutable_data();
  long *rd = rows.mutable_data(), *sd = steps.mutable_data(), *fd = failed.mutable_data();
  const double *q0d = q0.data(), *p0d = p0.data();

  Control member_control;
  if (cancel) member_control.cancel = &cancel->flag;
  EnsembleControl control;
  if (!progress.is_none())
    control.progress = [progress](long done, long total) {
      py::gil_scoped_acquire gil;
      progress(done, total);
    };
  // Copies a member's run into the arrays: rows on the grid to their place; the last
  // row (the final or last finite state) to the *_final arrays, and to the grid as
  // well when it lies on it.
  auto store = [&](long i, RunResult&& r) {
    const Trajectory& tr = r.trajectory;
    long on_grid = 0;
    for (long row = 0; row < tr.rows() && row < R && tr.t[row] == grid[row]; ++row) on_grid = row + 1;
    std::copy(tr.q.begin(), tr.q.begin() + on_grid * n, qd + i * R * n);
    std::copy(tr.p.begin(), tr.p.begin() + on_grid * n, pd + i * R * n);
    std::copy(tr.energy.begin(), tr.energy.begin() + on_grid, ed + i * R);
    std::copy(tr.momentum.begin(), tr.momentum.begin() + on_grid * m, Jd + i * R * m);
    const long last = tr.rows() - 1;
    std::copy(tr.q.begin() + last * n, tr.q.begin() + (last + 1) * n, qf + i * n);
    std::copy(tr.p.begin() + last * n, tr.p.begin() + (last + 1) * n, pf + i * n);
    std::copy(tr.momentum.begin() + last * m, tr.momentum.begin() + (last + 1) * m, Jf + i * m);
    if (S > 0 && tr.n_springs == S) {  // its rows and last row, as q's
      auto copy = [&](const std::vector<double>& from, double* to, double* to_final) {
        std::copy(from.begin(), from.begin() + on_grid * S, to + i * R * S);
        std::copy(from.begin() + last * S, from.begin() + (last + 1) * S, to_final + i * S);
      };
      copy(tr.spring_force, sfd, sffd);
      copy(tr.spring_deformation, sdd, sdfd);
    }
    tf[i] = tr.t[last];
    ef[i] = tr.energy[last];
    rd[i] = on_grid;
    sd[i] = r.steps;
    fd[i] = r.failed_step;
    dd[i] = r.max_momentum_drift;
    status[i] = status_name(r.status);
    message[i] = std::move(r.message);
    if (events) member_events[i] = std::move(r.events);
    if (envelope) member_envelopes[i] = std::move(r.envelope);
    if (dense) member_dense[i] = std::move(r.dense);
  };
  int factorisations = 0;  // of the linear implicit methods, over the whole ensemble
  {
    py::gil_scoped_release release;
    EnsembleSpec ens{spec, first_stream, threads, vector_sine};
    with_method_for<Model>(method, [&](auto method_tag) {
      factorisations = run_members<decltype(method_tag)>(member_model, member_load, q0d, p0d, tab, comp, ens,
                                                         member_control, control, store);
      return 0;
    });
  }
  py::dict out;
  out["tableau"] = tab.name();
  out["t"] = py::array_t<double>(R, grid.data());
  out["q"] = q;
  out["p"] = p;
  out["energy"] = e;
  out["momentum"] = J;
  out["rows"] = rows;
  out["t_final"] = t_final;
  out["q_final"] = q_final;
  out["p_final"] = p_final;
  out["energy_final"] = e_final;
  out["momentum_final"] = J_final;
  out["steps"] = steps;
  out["failed_step"] = failed;
  out["max_momentum_drift"] = drift;
  out["status"] = status;
  out["message"] = message;
  out["threads"] = ensemble_threads(threads, members);
  out["factorisations"] = factorisations;
  if (S > 0) {
    out["spring_force"] = sf;
    out["spring_deformation"] = sdef;
    out["spring_force_final"] = sf_final;
    out["spring_deformation_final"] = sdef_final;
  }
  if (events) out["events"] = ensemble_events(std::move(member_events), n);
  if (envelope) out["envelope"] = ensemble_envelopes(member_envelopes);
  if (dense) {  // each member's, as a single run's (its own number of step ends)
    py::list records;
    for (DenseRecord& record : member_dense) records.append(dense_dict(std::move(record)));
    out["dense"] = records;
  }
  return out;
}

// Registers run_ensemble<Model> as the static method `integrate_ensemble` of
// Model's class (one function per kind; see def_integrate in run.hpp for why not
// overloads of one module function).
template <class Model>
void def_integrate_ensemble(py::module_&) {
  auto cls = py::reinterpret_borrow<py::class_<Model>>(py::type::of<Model>());
  cls.def_static("integrate_ensemble", &run_ensemble<Model>, py::arg("models"), py::arg("model_index"),
                 py::arg("names"), py::arg("values"), py::arg("method"), py::arg("tableau"), py::arg("composition"),
                 py::arg("q0"), py::arg("p0"), py::arg("h"), py::arg("n_steps"), py::arg("h_last"),
                 py::arg("save_every"), py::arg("threads"), py::arg("progress"), py::arg("cancel").none(true),
                 py::arg("vector_sine") = false, py::arg("loads") = std::vector<const BoundLoad*>{},
                 py::arg("load_index") = py::array_t<long>(), py::arg("temperature") = 0.0, py::arg("seed") = 0,
                 py::arg("first_stream") = 0, py::arg("events").none(true) = py::none(),
                 py::arg("envelope").none(true) = py::none(), py::arg("dense") = false);
}

}  // namespace raydamp::bindings
