// The envelope a run records (raydamp/record/envelope.hpp): an EnvelopeSpec of the peaks to take and the
// springs' collapse limits, built by python/raydamp/run/envelope.py, which names and checks them.
#include <pybind11/stl.h>

#include <string>
#include <vector>

#include "bindings.hpp"
#include "raydamp/record/envelope_types.hpp"

namespace py = pybind11;

namespace raydamp::bindings {

void bind_envelope(py::module_& m) {
  py::tuple names(kPeaks);
  for (int k = 0; k < kPeaks; ++k) names[k] = kPeakNames[k];
  m.attr("PEAKS") = names;
  py::class_<EnvelopeSpec>(m, "EnvelopeSpec")
      .def(py::init([](const std::vector<std::string>& peaks, const std::vector<double>& collapse,
                       const std::vector<int>& labels) {
             EnvelopeSpec spec;
             for (const std::string& name : peaks) {
               int k = 0;
               while (k < kPeaks && name != kPeakNames[k]) ++k;
               if (k == kPeaks) throw std::invalid_argument("envelope: unknown peak '" + name + "'");
               spec.peaks[k] = true;
             }
             spec.collapse = collapse;
             spec.labels = labels;
             return spec;
           }),
           py::arg("peaks"), py::arg("collapse") = std::vector<double>{}, py::arg("labels") = std::vector<int>{});
}

}  // namespace raydamp::bindings
