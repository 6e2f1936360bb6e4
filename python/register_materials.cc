#include <pybind11/stl.h>

#include "porthole/materials/materials.h"
#include "register.h"

namespace py = pybind11;

namespace porthole::python {

void RegisterMaterials(py::module_& m) {
  m.def(
      "index",
      [](const std::string& medium, double lambda_nm, double temperature_c, double salinity_psu,
         double pressure_dbar, bool extrapolate) {
        materials::Conditions c;
        c.lambda_nm = lambda_nm;
        c.temperature_c = temperature_c;
        c.salinity_psu = salinity_psu;
        c.pressure_dbar = pressure_dbar;
        c.extrapolate = extrapolate;
        return materials::Index(medium, c);
      },
      py::arg("medium"), py::kw_only(), py::arg("lambda_nm") = materials::kDefaultLambdaNm,
      py::arg("temperature_c") = 20.0, py::arg("salinity_psu") = 35.0, py::arg("pressure_dbar") = 0.0,
      py::arg("extrapolate") = false,
      "Refractive index of a medium relative to air at the same wavelength ('seawater', 'n-bk7', ...).");
  m.def("media", [] {
    py::list out;
    for (const auto& i : materials::ListMedia()) out.append(py::make_tuple(i.name, i.description));
    return out;
  }, "The known media as (name, description) pairs.");
  m.def("depth_to_pressure_dbar", &materials::DepthToPressureDbar, py::arg("depth_m"),
        py::arg("latitude_deg") = 45.0, "Depth (m) to gauge pressure (dbar), UNESCO 1983.");
}

}  // namespace porthole::python
