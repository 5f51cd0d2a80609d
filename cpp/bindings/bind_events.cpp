// The events a run locates (raydamp/events/): an EventSet built from Python's compiled event
// functions (python/raydamp/run/events.py), which keeps them alive while a run holds the set.
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
      .def("add",
           [](EventSet& set, std::uintptr_t fn, std::uintptr_t data, const std::vector<std::tuple<int, int>>& slots,
              int direction, bool terminal, const std::string& name) {
             EventFunction ev;
             ev.fn.fn = reinterpret_cast<CompiledFunction::Fn>(fn);
             ev.fn.data = reinterpret_cast<void*>(data);
             for (const auto& [kind, index] : slots) {
               if (kind < 0 || kind > static_cast<int>(EventSlot::Kind::f))
                 throw std::invalid_argument("events: slot kind " + std::to_string(kind) + " is not one of t, q, p, v, f");
               ev.slots.push_back({static_cast<EventSlot::Kind>(kind), index});
             }
             ev.direction = direction;
             ev.terminal = terminal;
             ev.name = name;
             set.events.push_back(std::move(ev));
           },
           py::arg("fn"), py::arg("data"), py::arg("slots"), py::arg("direction"), py::arg("terminal"), py::arg("name"))
      .def("__len__", [](const EventSet& set) { return set.events.size(); });
}

}  // namespace raydamp::bindings
