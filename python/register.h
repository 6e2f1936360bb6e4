#pragma once

#include <pybind11/pybind11.h>

namespace porthole::python {

void RegisterMaterials(pybind11::module_& m);
void RegisterPorts(pybind11::module_& m);
void RegisterCalib(pybind11::module_& m);
void RegisterPlanning(pybind11::module_& m);
void RegisterSimulate(pybind11::module_& m);

}  // namespace porthole::python
