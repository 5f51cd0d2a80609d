// The built-in models' integrate and integrate_ensemble (methods of their classes), the CancelToken every run
// takes, the run statuses and the save grid.
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
  py::tuple statuses(kStatusNames.size());
  for (std::size_t i = 0; i < kStatusNames.size(); ++i) statuses[i] = kStatusNames[i];
  m.attr("STATUSES") = statuses;
  m.attr("DEFAULT_DIVERGENCE") = kDefaultDivergence;
  m.def("save_rows", &save_rows, py::arg("n_steps"), py::arg("save_every"));
  m.def("save_grid", [](double h, long n_steps, double h_last, long save_every) {
    std::vector<double> grid = save_grid(h, n_steps, h_last, save_every);
    return py::array_t<double>(static_cast<py::ssize_t>(grid.size()), grid.data());
  }, py::arg("h"), py::arg("n_steps"), py::arg("h_last"), py::arg("save_every"));
  for_each_builtin_model([&](auto tag, const char*) {
    using Model = typename decltype(tag)::type;
    def_integrate<Model>(m);
    def_integrate_ensemble<Model>(m);
  });
}

}  // namespace raydamp::bindings
