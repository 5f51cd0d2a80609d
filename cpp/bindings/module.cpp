// raydamp._core: private; the public names and their documentation live in Python.
#include "bindings.hpp"

#include <stdexcept>

#include "raydamp/errors.hpp"

namespace py = pybind11;

PYBIND11_MODULE(_core, m) {
  m.doc() = "raydamp's compiled core (private: use the raydamp package)";
  m.attr("__version__") = RAYDAMP_VERSION;
  // Named in Python as raydamp.ChebyshevDegreeError (documented there).
  py::register_exception<raydamp::ChebyshevDegreeError>(m, "ChebyshevDegreeError", PyExc_ValueError);
  raydamp::bindings::bind_catalogue(m);
  raydamp::bindings::bind_load(m);
  raydamp::bindings::bind_events(m);  // before the kinds, whose integrate takes an EventSet
  raydamp::bindings::bind_envelope(m);  // and an EnvelopeSpec
  raydamp::bindings::bind_models(m);
  raydamp::bindings::bind_integrate(m);
  raydamp::bindings::bind_system_scalar_mass(m);
  raydamp::bindings::bind_system_dense_mass(m);
  raydamp::bindings::bind_constrained_system(m);
  raydamp::bindings::bind_chain(m);
  raydamp::bindings::bind_linear_structure(m);
  raydamp::bindings::bind_structure(m);
  raydamp::bindings::bind_kepler(m);
}
