// The events a run locates (raydamp/events/): an EventSet of the events' directions and names and the
// one function that computes every g (python/raydamp/run/events.py, which keeps it alive while a run
// holds the set).
#include <pybind11/stl.h>

#include <cstdint>
#include <string>
#include <tuple>
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
           [](EventSet& set, int direction, bool terminal, const std::string& name) {
             set.events.push_back({direction, terminal, name});
           },
           py::arg("direction"), py::arg("terminal"), py::arg("name"))
      .def("__len__", [](const EventSet& set) { return set.events.size(); });
}

}  // namespace raydamp::bindings
