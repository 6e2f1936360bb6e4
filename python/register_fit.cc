// Python bindings of pointcloud and fit: read a scan, fit a sphere to it, analyse a dome from the
// scans of its two surfaces (paper Section 3, Table 3). Points are (N, 3) numpy arrays in mm; the
// results are dicts of floats and numpy arrays that the package turns into SphereFit / DomeFit.
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include "porthole/core/error.h"
#include "porthole/core/field_names.h"
#include "porthole/fit/assembly.h"
#include "porthole/fit/dome.h"
#include "porthole/fit/sphere_fit.h"
#include "porthole/catalogue/presets.h"
#include "porthole/pointcloud/pointcloud.h"
#include "register.h"

namespace py = pybind11;

namespace porthole::python {
namespace {

// (N, 3) array → 3×N matrix; `field` names the keyword in errors.
Eigen::Matrix3Xd Points(const py::array_t<double, py::array::c_style | py::array::forcecast>& a,
                        const std::string& field) {
  if (a.ndim() != 2 || a.shape(1) != 3) throw InvalidInput(field, "must be an (N, 3) array of points in mm");
  const auto p = a.unchecked<2>();
  Eigen::Matrix3Xd m(3, p.shape(0));
  for (py::ssize_t i = 0; i < p.shape(0); ++i) {
    for (int k = 0; k < 3; ++k) m(k, i) = p(i, k);
  }
  return m;
}

fit::SphereFitOptions SphereOptions(bool robust, const std::string& loss, double threshold_mm) {
  fit::SphereFitOptions o;
  o.robust = robust;
  if (loss != "cauchy" && loss != "huber") throw InvalidInput("loss", "must be 'cauchy' or 'huber'");
  o.loss = loss == "huber" ? fit::RobustLoss::kHuber : fit::RobustLoss::kCauchy;
  if (!(threshold_mm > 0)) throw InvalidInput("threshold_mm", "must be > 0 mm");
  o.inlier_threshold_mm = threshold_mm;
  return o;
}

py::dict SphereDict(const fit::SphereFitSummary& s) {
  py::dict d;
  d["center_mm"] = Eigen::Vector3d(s.sphere.center_mm);
  d["radius_mm"] = s.sphere.radius_mm;
  d["sigma_center_mm"] = Eigen::Vector3d(s.sigma_center_mm);
  d["sigma_radius_mm"] = s.sigma_radius_mm;
  d["covariance_mm2"] = Eigen::Matrix4d(s.covariance);
  d["sigma0_mm"] = s.sigma0_mm;
  d["rms_mm"] = s.rms_mm;
  d["max_abs_residual_mm"] = s.max_abs_residual_mm;
  d["n_points"] = s.n_points;
  d["n_inliers"] = s.n_inliers;
  d["converged"] = s.converged;
  d["usable"] = s.IsUsable();
  d["message"] = s.message;
  d["residuals_mm"] = Eigen::VectorXd(s.residuals_mm);
  py::array_t<bool> inl(static_cast<py::ssize_t>(s.is_inlier.size()));
  auto w = inl.mutable_unchecked<1>();
  for (std::size_t i = 0; i < s.is_inlier.size(); ++i) w(static_cast<py::ssize_t>(i)) = s.is_inlier[i];
  d["is_inlier"] = inl;
  return d;
}

fit::PlaneWithCenter Plane(const std::array<double, 6>& p) {
  return {{p[0], p[1], p[2]}, {p[3], p[4], p[5]}};
}

}  // namespace

void RegisterFit(py::module_& m) {
  m.def(
      "read_point_cloud",
      [](const std::string& path) {
        const auto cloud = pointcloud::ReadPointCloud(path);
        return Eigen::MatrixX3d(cloud.points.transpose());
      },
      py::arg("path"),
      "The points of a scan file (PLY, XYZ/CSV/TXT, OBJ, STL) as an (N, 3) array, mm.");
  m.def(
      "fit_sphere",
      [](const py::array_t<double, py::array::c_style | py::array::forcecast>& points, bool robust,
         const std::string& loss, double threshold_mm) {
        const auto p = Points(points, "points");
        const auto o = SphereOptions(robust, loss, threshold_mm);
        fit::SphereFitSummary s;
        {
          py::gil_scoped_release release;
          s = fit::FitSphere(p, o);
        }
        return SphereDict(s);
      },
      py::arg("points"), py::kw_only(), py::arg("robust") = false, py::arg("loss") = "cauchy",
      py::arg("threshold_mm") = fit::SphereFitOptions{}.inlier_threshold_mm,
      "Sphere fit to (N, 3) points in mm (as `porthole fit sphere --json`).");
  m.def(
      "analyze_dome",
      [](const py::array_t<double, py::array::c_style | py::array::forcecast>& outer,
         const py::array_t<double, py::array::c_style | py::array::forcecast>& inner, bool robust,
         const std::string& loss, double threshold_mm, double nominal_outer_radius_mm,
         double nominal_thickness_mm) {
        const auto po = Points(outer, "outer_points"), pi = Points(inner, "inner_points");
        WithFieldNames({{"points", "outer_points"}}, [&] { fit::CheckSpherePoints(po); });
        WithFieldNames({{"points", "inner_points"}}, [&] { fit::CheckSpherePoints(pi); });
        fit::DomeAnalysisOptions o;
        o.sphere = SphereOptions(robust, loss, threshold_mm);
        if (!(nominal_outer_radius_mm >= 0)) throw InvalidInput("nominal_outer_radius_mm", "must be >= 0 mm (0: none)");
        if (!(nominal_thickness_mm >= 0)) throw InvalidInput("nominal_thickness_mm", "must be >= 0 mm (0: none)");
        o.nominal_outer_radius_mm = nominal_outer_radius_mm;
        o.nominal_thickness_mm = nominal_thickness_mm;
        fit::DomeAnalysis a;
        {
          py::gil_scoped_release release;
          a = fit::AnalyzeDome(po, pi, o);
        }
        py::dict d;
        d["outer"] = SphereDict(a.outer);
        d["inner"] = SphereDict(a.inner);
        d["thickness_mm"] = a.thickness_mm;
        d["sigma_thickness_mm"] = a.sigma_thickness_mm;
        d["center_offset_mm"] = Eigen::Vector3d(a.center_offset_mm);
        d["center_distance_mm"] = a.center_distance_mm;
        d["sigma_center_distance_mm"] = a.sigma_center_distance_mm;
        d["min_wall_mm"] = a.min_wall_mm;
        d["max_wall_mm"] = a.max_wall_mm;
        d["outer_radius_deviation_mm"] = a.outer_radius_deviation_mm;
        d["thickness_deviation_mm"] = a.thickness_deviation_mm;
        d["usable"] = a.IsUsable();
        d["report"] = a.Report();
        return d;
      },
      py::arg("outer_points"), py::arg("inner_points"), py::kw_only(), py::arg("robust") = false,
      py::arg("loss") = "cauchy", py::arg("threshold_mm") = fit::SphereFitOptions{}.inlier_threshold_mm,
      py::arg("nominal_outer_radius_mm") = 0.0, py::arg("nominal_thickness_mm") = 0.0,
      "Dome shell from scans of its outer and inner surfaces: both spheres, thickness, centre "
      "offset, wall extremes (the paper's Table 3).");

  m.def(
      "assemble",
      [](const std::array<double, 4>& outer, const std::array<double, 4>& inner,
         const std::array<double, 6>& housing_flange, const std::array<double, 6>& camera_flange,
         const std::optional<std::array<double, 6>>& dome_rear, bool dome_centered,
         const Eigen::Vector3d& x_hint, const Eigen::Vector3d& dome_x_hint,
         std::optional<double> pupil_to_flange_mm, const std::string& lens, std::optional<double> focus_mm,
         const std::string& material, const std::string& name) {
        return WithFieldNames(
            {{"outer", "outer"}, {"inner", "inner"}, {"housing_flange", "housing_flange"},
             {"camera_flange", "camera_flange"}, {"dome_rear", "dome_rear"}, {"dome_centered", "dome_centered"},
             {"x_hint", "x_hint"}, {"dome_x_hint", "dome_x_hint"}, {"pupil_offset", "pupil_to_flange_mm"},
             {"lens", "lens"}, {"focus", "focus_mm"}, {"port", "name"}},
            [&] {
              fit::AssemblyInput in;
              in.camera_flange = Plane(camera_flange);
              in.housing_flange = Plane(housing_flange);
              in.outer = {{outer[0], outer[1], outer[2]}, outer[3]};
              in.inner = {{inner[0], inner[1], inner[2]}, inner[3]};
              if (dome_rear) in.dome_rear = Plane(*dome_rear);
              in.dome_centered = dome_centered;
              in.survey_x_hint = x_hint;
              in.scan_x_hint = dome_x_hint;
              if (!lens.empty() == pupil_to_flange_mm.has_value()) {
                throw InvalidInput("pupil_to_flange_mm", "give pupil_to_flange_mm, or lens and focus_mm");
              }
              if (!lens.empty()) {
                if (!focus_mm) throw InvalidInput("focus_mm", "required with lens (mm, math.inf allowed)");
                in.pupil_to_flange_mm = catalogue::LoadLens(lens).PupilToFlangeMm(*focus_mm);
              } else {
                in.pupil_to_flange_mm = *pupil_to_flange_mm;
              }
              const fit::HousingAssembly a = fit::AssembleHousing(in);
              py::dict d = JsonToPython(fit::AssemblyToJson(a, in.pupil_to_flange_mm)).cast<py::dict>();
              d["report"] = a.Report();
              d["port"] = py::cast(fit::AsBuiltPort(a, name, material));
              return d;
            });
      },
      py::kw_only(), py::arg("outer"), py::arg("inner"), py::arg("housing_flange"),
      py::arg("camera_flange") = std::array<double, 6>{0, 0, 0, 0, 0, 1}, py::arg("dome_rear") = py::none(),
      py::arg("dome_centered") = false, py::arg("x_hint") = Eigen::Vector3d(1, 0, 0),
      py::arg("dome_x_hint") = Eigen::Vector3d(1, 0, 0), py::arg("pupil_to_flange_mm") = py::none(),
      py::arg("lens") = "", py::arg("focus_mm") = py::none(), py::arg("material") = "n-bk7",
      py::arg("name") = "as-built",
      "The camera-housing-dome geometry from separate measurements (paper Section 3.4, Table 4; as "
      "`porthole assemble --json`): spheres (x, y, z, R) or SphereFit, planes (x, y, z, nx, ny, nz), the "
      "pupil from pupil_to_flange_mm or lens and focus_mm. Returns the Table 4 quantities and `port`, "
      "the as-built PortSpec (its to_toml() is the file `porthole assemble -o` writes).");
}

}  // namespace porthole::python
