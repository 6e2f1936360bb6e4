// The Python module `porthole`: the libraries' functions for notebooks. Options are keyword
// arguments (a typo raises TypeError); bad input raises ValueError with the field named.
#include <pybind11/pybind11.h>

#include "register.h"

PYBIND11_MODULE(porthole, m) {
  m.doc() = "porthole: optics and geometry of underwater camera housings (mm, nm, degC, PSU, dbar)";
  porthole::python::RegisterMaterials(m);
  porthole::python::RegisterPorts(m);
  porthole::python::RegisterCalib(m);
  porthole::python::RegisterPlanning(m);
  porthole::python::RegisterSimulate(m);
}
