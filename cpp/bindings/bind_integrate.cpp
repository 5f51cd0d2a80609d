// The built-in models' integrate and integrate_ensemble (methods of their classes), and the CancelToken every run takes.
#include "builtin_models.hpp"
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
  for_each_builtin_model([&](auto tag, const char*) {
    using Model = typename decltype(tag)::type;
    def_integrate<Model>(m);
    def_integrate_ensemble<Model>(m);
  });
}

}  // namespace raydamp::bindings
