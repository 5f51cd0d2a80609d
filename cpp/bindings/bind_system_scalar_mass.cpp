// Compiled systems with M = m I (a split across files so the kinds compile in parallel).
#include "bind_system.hpp"

namespace raydamp::bindings {

void bind_system_scalar_mass(py::module_& m) {
  bind_system_kind<ScalarMass, IsotropicDamping>(m, "System_scalar_isotropic");
  bind_system_kind<ScalarMass, ConstantDamping>(m, "System_scalar_constant");
  bind_system_kind<ScalarMass, DamperDamping>(m, "System_scalar_dampers");
}

}  // namespace raydamp::bindings
