// _core.Load: a load as data (raydamp/load.hpp), built from the terms Python checked
// (python/raydamp/loads): each a dict with "shape" and that shape's fields.
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <memory>
#include <string>
#include <vector>

#include "bindings.hpp"
#include "load_binding.hpp"
#include "raydamp/response_spectrum.hpp"

namespace py = pybind11;

namespace raydamp::bindings {

namespace {

template <class T>
std::vector<T> numbers(const py::dict& d, const char* key) {
  return d[key].cast<std::vector<T>>();
}

LoadTerm term_from(const py::dict& d) {
  LoadTerm term;
  const std::string shape = d["shape"].cast<std::string>();
  term.scale = d.contains("scale") ? d["scale"].cast<double>() : 1.0;
  term.time_scale = d.contains("time_scale") ? d["time_scale"].cast<double>() : 1.0;
  if (d.contains("index")) {
    auto direction = std::make_shared<LoadDirection>();
    direction->index = numbers<int>(d, "index");
    direction->value = numbers<double>(d, "value");
    term.direction = std::move(direction);
  }
  if (d.contains("ground_index")) {  // a ground motion's influence vector r
    auto ground = std::make_shared<LoadDirection>();
    ground->index = numbers<int>(d, "ground_index");
    ground->value = numbers<double>(d, "ground_value");
    term.ground = std::move(ground);
  }
  if (shape == "harmonic") {
    term.shape = LoadTerm::Shape::harmonic;
    term.omega = d["omega"].cast<double>();
    term.phase = d["phase"].cast<double>();
    if (d.contains("t_end")) term.t_end = d["t_end"].cast<double>();
  } else if (shape == "series") {
    term.shape = LoadTerm::Shape::series;
    auto series = std::make_shared<LoadSeries>();
    series->times = numbers<double>(d, "times");
    series->values = numbers<double>(d, "values");
    series->width = d["width"].cast<int>();
    series->hold = d["hold"].cast<bool>();
    series->step = d["step"].cast<double>();
    term.series = std::move(series);
  } else if (shape == "expression") {
    term.shape = LoadTerm::Shape::expression;
    const auto address = d["function"].cast<std::pair<std::uintptr_t, std::uintptr_t>>();
    term.expression.fn = reinterpret_cast<CompiledFunction::Fn>(address.first);
    term.expression.data = reinterpret_cast<void*>(address.second);
  } else {
    throw std::invalid_argument("load: unknown shape '" + shape + "'");
  }
  return term;
}

}  // namespace

void bind_load(py::module_& m) {
  py::class_<BoundLoad>(m, "Load")
      .def(py::init([](int n, const py::list& terms, py::object owners) {
             std::vector<LoadTerm> built;
             for (const auto& t : terms) built.push_back(term_from(t.cast<py::dict>()));
             return BoundLoad{Load(std::move(built), n), std::move(owners)};
           }),
           py::arg("n"), py::arg("terms"), py::arg("owners") = py::none())
      // The same load with every term's scale times `scale`, harmonic frequencies times
      // `frequency` and histories run `frequency` times faster (data shared): an ensemble member's.
      .def("scaled", [](const BoundLoad& b, double scale, double frequency) {
             std::vector<LoadTerm> terms = b.load.terms();
             for (LoadTerm& t : terms) {
               t.scale *= scale;
               t.omega *= frequency;
               t.time_scale *= frequency;
             }
             return BoundLoad{Load(std::move(terms), b.load.size()), b.owners};
           }, py::arg("scale"), py::arg("frequency"))
      .def_property_readonly("n", [](const BoundLoad& b) { return b.load.size(); })
      // f(t) at each of the times (rows), and f(t) . v row by row: what a Solution reads back.
      .def("values", [](const BoundLoad& b, const std::vector<double>& times) {
             const int n = b.load.size();
             py::array_t<double> out({static_cast<py::ssize_t>(times.size()), static_cast<py::ssize_t>(n)});
             double* d = out.mutable_data();
             std::fill(d, d + out.size(), 0.0);
             for (std::size_t k = 0; k < times.size(); ++k) b.load.add(times[k], 1.0, d + k * n);
             return out;
           }, py::arg("times"));
  // Peak |u| over the sample times of each oscillator under a piecewise-linear record (raydamp.response_spectrum
  // checks the arguments and names them).
  m.def("elastic_peaks", [](const py::array_t<double, py::array::c_style | py::array::forcecast>& omega, double zeta,
                            const py::array_t<double, py::array::c_style | py::array::forcecast>& times,
                            const py::array_t<double, py::array::c_style | py::array::forcecast>& accel) {
    if (omega.ndim() != 1 || times.ndim() != 1 || accel.ndim() != 1 || times.size() != accel.size())
      throw std::invalid_argument("elastic_peaks: omega, times and accel must be vectors, times and accel alike");
    py::array_t<double> peaks(omega.size());
    const double* w = omega.data();
    const double* t = times.data();
    const double* a = accel.data();
    double* out = peaks.mutable_data();
    {
      py::gil_scoped_release release;
      elastic_peaks(w, static_cast<std::size_t>(omega.size()), zeta, t, a, static_cast<std::size_t>(times.size()),
                    out);
    }
    return peaks;
  }, py::arg("omega"), py::arg("zeta"), py::arg("times"), py::arg("accel"));
}

}  // namespace raydamp::bindings
