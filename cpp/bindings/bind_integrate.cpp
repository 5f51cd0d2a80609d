// The built-in models' integrate and integrate_ensemble (methods of their classes), and the CancelToken every run takes.
#include "run.hpp"
#include "run_ensemble.hpp"

namespace py = pybind11;

namespace raydamp::bindings {

void bind_integrate(py::module_& m) {
  py::class_<CancelToken>(m, "CancelToken")
      .def(py::init<>())
      .def("cancel", [](CancelToken& c) { c.flag.store(true); })
      .def("reset", [](CancelToken& c) { c.flag.store(false); })
      .def_property_readonly("cancelled", [](const CancelToken& c) { return c.flag.load(); });
  def_integrate<DampedPendulum>(m);
  def_integrate<ElasticPendulum>(m);
  def_integrate_ensemble<DampedPendulum>(m);
  def_integrate_ensemble<ElasticPendulum>(m);
}

}  // namespace raydamp::bindings
