#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <limits>

#include "porthole/core/field_names.h"
#include "porthole/catalogue/presets.h"
#include "porthole/housing/plausible.h"
#include "porthole/optics/batch.h"
#include "porthole/ports/describe.h"
#include "porthole/ports/environment.h"
#include "porthole/ports/virtual_image.h"
#include "register.h"

namespace py = pybind11;

namespace porthole::python {
namespace {

using ports::Vec3;

py::dict ToDict(const ports::VirtualImage& v) {
  py::dict d;
  d["wd_mm"] = v.wd_mm;
  d["d_s2ep_mm"] = v.d_s2ep_mm;
  d["vwd_mm"] = v.vwd_mm;
  d["magnification"] = v.magnification;
  d["lateral_offset_mm"] = v.lateral_offset_mm;
  d["focal_line_near_d_s2ep_mm"] = v.focal_line_near_d_s2ep_mm;
  d["focal_line_far_d_s2ep_mm"] = v.focal_line_far_d_s2ep_mm;
  return d;
}

// Traces N rays given as (N, 3) arrays through `seq`; returns origins, directions and status codes
// (0 ok, 1 missed, 2 outside aperture, 3 total internal reflection).
py::tuple TraceArrays(const std::vector<optics::Interface>& seq, const py::array_t<double>& origins,
                      const py::array_t<double>& directions) {
  if (origins.ndim() != 2 || origins.shape(1) != 3 || directions.ndim() != 2 ||
      directions.shape(1) != 3 || origins.shape(0) != directions.shape(0)) {
    throw py::value_error("origins and directions must be arrays of the same shape (N, 3)");
  }
  const auto o = origins.unchecked<2>();
  const auto d = directions.unchecked<2>();
  optics::RayBatch batch;
  batch.resize(static_cast<std::size_t>(o.shape(0)));
  for (py::ssize_t i = 0; i < o.shape(0); ++i) {
    const Vec3 dir(d(i, 0), d(i, 1), d(i, 2));
    batch.Set(static_cast<std::size_t>(i), {Vec3(o(i, 0), o(i, 1), o(i, 2)), dir.normalized()});
  }
  {
    py::gil_scoped_release release;
    optics::TraceBatch(seq, &batch);
  }
  py::array_t<double> out_o({o.shape(0), py::ssize_t(3)}), out_d({o.shape(0), py::ssize_t(3)});
  py::array_t<int> status(o.shape(0));
  auto oo = out_o.mutable_unchecked<2>();
  auto dd = out_d.mutable_unchecked<2>();
  auto ss = status.mutable_unchecked<1>();
  for (py::ssize_t i = 0; i < o.shape(0); ++i) {
    const auto k = static_cast<std::size_t>(i);
    oo(i, 0) = batch.ox[k], oo(i, 1) = batch.oy[k], oo(i, 2) = batch.oz[k];
    dd(i, 0) = batch.dx[k], dd(i, 1) = batch.dy[k], dd(i, 2) = batch.dz[k];
    ss(i) = static_cast<int>(batch.status[k]);
  }
  return py::make_tuple(out_o, out_d, status);
}

}  // namespace

void RegisterPorts(py::module_& m) {
  py::class_<ports::PortSpec>(m, "PortSpec", "A dome, flat or cylindrical port as described by a preset or TOML file.")
      .def_readonly("name", &ports::PortSpec::name, "The preset's or file's name.")
      .def_readonly("description", &ports::PortSpec::description, "What the port is, with its source.")
      .def_property_readonly("_type", [](const ports::PortSpec& p) { return std::string(p.KindName()); })
      .def_property_readonly("material", &ports::PortSpec::material, "The glass (a medium of media()).")
      .def("to_toml", &catalogue::PortToToml, "The port as a TOML file's text (the schema of docs/presets.md).")
      .def("__repr__", [](const ports::PortSpec& p) { return "<PortSpec " + p.name + ">"; });

  m.def(
      "load_port",
      [](const std::string& name_or_path) {
        return WithFieldNames({{"port", "name_or_path"}}, [&] { return catalogue::LoadPort(name_or_path); });
      },
      py::arg("name_or_path"),
        "A built-in port preset by name (see presets()) or a port TOML file.");
  m.def(
      "port_shapes",
      [] {
        py::list out;
        for (std::string_view name : ports::ShapeNames()) out.append(std::string(name));
        return out;
      },
      "The port shapes, in the list's order (ports/port.h PortShape): the values of PortType.");
  m.def(
      "presets",
      [] {
        py::list out;
        for (const auto& p : catalogue::BuiltinPresets()) {
          out.append(py::make_tuple(std::string(p.kind), std::string(p.name), catalogue::PresetDescription(p)));
        }
        return out;
      },
      "The built-in presets (ports, cameras, lenses) as (kind, name, description).");

  py::class_<ports::PortSystem>(m, "PortSystem", "A port placed in front of an entrance pupil, indices resolved.")
      .def_readonly("n_glass", &ports::PortSystem::n_glass, "Glass index relative to air.")
      .def_readonly("n_water", &ports::PortSystem::n_water, "Water index relative to air.")
      .def_readonly("ep_in_housing_mm", &ports::PortSystem::ep_in_housing_mm, "Entrance pupil, housing frame, mm.")
      .def_property_readonly("_type", [](const ports::PortSystem& s) { return std::string(s.spec.KindName()); })
      .def_property_readonly("is_central", [](const ports::PortSystem& s) { return s.IsCentral(); })
      .def_property_readonly("outer_vertex_z_mm", &ports::PortSystem::OuterVertexZ)
      .def(
          "describe", [](const ports::PortSystem& s) { return JsonToPython(ports::PortJson(s)); },
          "The port as the CLI's JSON gives it (its `port` block of `porthole virtual-image --json`): name, type, "
          "material, glass_index, the shape's fields (housing frame, mm), outer_vertex_z_mm.")
      .def(
          "virtual_image",
          [](const ports::PortSystem& s, double wd_mm) { return ToDict(ports::ParaxialVirtualImage(s, wd_mm)); },
          py::arg("wd_mm"), "Paraxial virtual image of an axial object at wd_mm (float('inf') allowed).")
      .def(
          "virtual_image_real",
          [](const ports::PortSystem& s, double wd_mm, double h) -> py::object {
            const auto v = ports::RealRayVirtualImage(s, wd_mm, h);
            return v ? py::object(ToDict(*v)) : py::none();
          },
          py::arg("wd_mm"), py::arg("aperture_height_mm") = 1.5,
          "Real-ray virtual image through a pupil circle of the given radius; None if rays fail.")
      .def(
          "focal",
          [](const ports::PortSystem& s) {
            const auto f = ports::ParaxialFocal(s);
            py::dict d;
            d["power_per_mm"] = f.power_per_mm;
            d["efl_air_mm"] = f.efl_mm;
            d["efl_water_mm"] = f.efl_water_mm;
            d["back_focal_mm"] = f.back_focal_mm;
            d["front_focal_mm"] = f.front_focal_mm;
            return d;
          },
          "Paraxial focal properties: power_per_mm, efl_air_mm, efl_water_mm, back_focal_mm, front_focal_mm.")
      .def(
          "trace_out",
          [](const ports::PortSystem& s, const py::array_t<double>& o, const py::array_t<double>& d) {
            return TraceArrays(s.Outward(), o, d);
          },
          py::arg("origins_mm"), py::arg("directions"),
          "Trace (N,3) rays from inside the housing out into the water (batched, all cores).")
      .def(
          "trace_in",
          [](const ports::PortSystem& s, const py::array_t<double>& o, const py::array_t<double>& d) {
            return TraceArrays(s.Inward(), o, d);
          },
          py::arg("origins_mm"), py::arg("directions"), "Trace (N,3) rays from the water into the housing.");

  m.def(
      "place",
      [](const ports::PortSpec& spec, const std::string& water, std::optional<double> water_index,
         std::optional<double> glass_index, std::optional<Vec3> ep_mm, double lambda_nm, double temperature_c,
         double salinity_psu, double pressure_dbar, bool extrapolate) {
        const ports::Environment env = MakeEnvironment(water, water_index, glass_index, lambda_nm,
                                                       temperature_c, salinity_psu, pressure_dbar, extrapolate);
        // The port's plausibility warnings (housing/plausible.h), as `porthole virtual-image` and
        // `trace` print them for --port.
        return py::make_tuple(ports::MakeSystem(spec, env, ep_mm), housing::PortPlausibilityWarnings(spec));
      },
      py::arg("port"), py::kw_only(), py::arg("water") = "seawater", py::arg("water_index") = py::none(),
      py::arg("glass_index") = py::none(), py::arg("ep_mm") = py::none(), py::arg("lambda_nm") = 546.07,
      py::arg("temperature_c") = 20.0, py::arg("salinity_psu") = 35.0, py::arg("pressure_dbar") = 0.0,
      py::arg("extrapolate") = false,
      "Place a port in front of the entrance pupil (housing frame, mm) in the given water. Returns (the system, "
      "the port's plausibility warnings).");
}

}  // namespace porthole::python
