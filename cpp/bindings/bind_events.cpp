// The events a run locates (raydamp/events/): an EventSet of the events' directions and names and the
// one function that computes every g (python/raydamp/run/events.py, which keeps it alive while a run
// holds the set).
#include <pybind11/stl.h>

#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "bindings.hpp"
#include "raydamp/events/types.hpp"

namespace py = pybind11;

namespace raydamp::bindings {

void bind_events(py::module_& m) {
  py::class_<EventSet>(m, "EventSet")
      .def(py::init<>())
      .def("set_function",
           [](EventSet& set, std::uintptr_t fn, std::uintptr_t data, const std::vector<std::tuple<int, int>>& slots) {
             set.fn.fn = reinterpret_cast<CompiledFunction::Fn>(fn);
             set.fn.data = reinterpret_cast<void*>(data);
             set.slots.clear();
             for (const auto& [kind, index] : slots) {
               if (kind < 0 || kind > static_cast<int>(EventSlot::Kind::f))
                 throw std::invalid_argument("events: slot kind " + std::to_string(kind) + " is not one of t, q, p, v, f");
               set.slots.push_back({static_cast<EventSlot::Kind>(kind), index});
             }
           },
           py::arg("fn"), py::arg("data"), py::arg("slots"))
      .def("add",
           [](EventSet& set, int direction, bool terminal, const std::string& name,
              const std::optional<std::vector<std::tuple<int, int, double>>>& terms, double constant, bool henon) {
             EventFunction e{direction, terminal, name};
             e.henon = henon;
             if (terms) {  // g = constant + sum of coefficient * (t, q_index or p_index)
               e.affine = true;
               e.constant = constant;
               for (const auto& [kind, index, coefficient] : *terms) {
                 if (kind < 0 || kind > static_cast<int>(EventSlot::Kind::p))
                   throw std::invalid_argument("events: an affine term's kind " + std::to_string(kind) +
                                               " is not one of t, q, p");
                 e.terms.push_back({static_cast<EventSlot::Kind>(kind), index, coefficient});
               }
             }
             set.events.push_back(std::move(e));
           },
           py::arg("direction"), py::arg("terminal"), py::arg("name"), py::kw_only(), py::arg("terms") = py::none(),
           py::arg("constant") = 0.0, py::arg("henon") = false)
      .def("__len__", [](const EventSet& set) { return set.events.size(); });
}

}  // namespace raydamp::bindings
