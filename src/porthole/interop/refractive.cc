// Refractive housings of refractive COLMAP and calibmar as porthole ports, and back (refractive.h;
// docs/interop.md, "Refractive COLMAP and calibmar"); calibmar's calibration.yaml itself is calibmar.cc.
#include "porthole/interop/refractive.h"

#include <fmt/format.h>

#include <cmath>

#include "porthole/core/error.h"
#include "porthole/interop/internal.h"

namespace porthole::interop {

using detail::kDomePortNames;
using detail::kFlatPortNames;
using detail::ShortNum;

ports::PortSpec PortFromRefractive(const RefractiveHousing& h, const std::string& field, double* n_water) {
  const auto& p = h.params;
  const auto where = [&](int i) {
    return field + ": " + std::string(h.model == "FLATPORT" ? kFlatPortNames[i] : kDomePortNames[i]);
  };
  for (int i = 5; i < 8; ++i) {
    if (!(p[i] >= 1 && p[i] < 5)) throw InvalidInput(where(i), "a refractive index must be in [1, 5)");
  }
  if (!(p[4] > 0)) throw InvalidInput(where(4), "the glass thickness must be > 0 m");
  const double na = p[5];
  ports::PortSpec port;
  port.frame = ports::PortFrame::kCam;
  port.source = "converted by porthole from refractive COLMAP / calibmar " + h.model + " parameters (metres)";
  const Eigen::Vector3d v(p[0], p[1], p[2]);
  if (h.model == "DOMEPORT") {
    if (!(p[3] > 0)) throw InvalidInput(where(3), "the inner radius must be > 0 m");
    ports::DomePort d;
    d.inner = {1000.0 * v, 1000.0 * p[3]};
    d.outer = {1000.0 * v, 1000.0 * (p[3] + p[4])};
    d.material = ShortNum(p[6] / na);
    port.name = "refractive-domeport";
    port.description = fmt::format("Dome from DOMEPORT: inner radius {:g} mm, {:g} mm thick, centre {:g}, {:g}, {:g} mm "
                                   "from the pupil", 1000 * p[3], 1000 * p[4], 1000 * v.x(), 1000 * v.y(), 1000 * v.z());
    port.shape = d;
  } else if (h.model == "FLATPORT") {
    if (std::abs(v.norm() - 1) > 1e-6) throw InvalidInput(where(0), "the normal Nx, Ny, Nz must be a unit vector");
    if (!(p[3] > 0)) throw InvalidInput(where(3), "the distance to the interface must be > 0 m");
    ports::FlatPort f;
    f.normal = v.normalized();
    f.inner_point_mm = 1000.0 * p[3] * f.normal;
    f.thickness_mm = 1000.0 * p[4];
    f.material = ShortNum(p[6] / na);
    port.name = "refractive-flatport";
    port.description = fmt::format("Flat port from FLATPORT: interface {:g} mm from the pupil, {:g} mm thick",
                                   1000 * p[3], 1000 * p[4]);
    port.shape = f;
  } else {
    throw InvalidInput(field, "'" + h.model.substr(0, 40) + "' is not a housing model (FLATPORT, DOMEPORT)");
  }
  if (n_water != nullptr) *n_water = p[7] / na;
  return port;
}

RefractiveHousing RefractiveFromPort(const ports::PortSpec& port, double n_glass, double n_water,
                                     const std::string& field) {
  if (!(n_glass >= 1) || !(n_water >= 1)) throw InvalidInput(field, "indices must be >= 1");
  // In the cam frame: a housing-frame port relative to its own entrance pupil.
  const Eigen::Vector3d origin =
      port.frame == ports::PortFrame::kCam ? Eigen::Vector3d::Zero() : port.default_ep_in_housing_mm;
  RefractiveHousing h;
  if (const auto* d = std::get_if<ports::DomePort>(&port.shape)) {
    const double offset = (d->outer.center_mm - d->inner.center_mm).norm();
    if (offset > 1e-9) {
      throw InvalidInput(field, fmt::format("refractive COLMAP's DOMEPORT is concentric, this dome's sphere "
                                            "centres are {:.4g} mm apart", offset));
    }
    const Eigen::Vector3d c = (d->inner.center_mm - origin) / 1000.0;
    h.model = "DOMEPORT";
    h.params = {c.x(), c.y(), c.z(), d->inner.radius_mm / 1000.0,
                (d->outer.radius_mm - d->inner.radius_mm) / 1000.0, 1.0, n_glass, n_water};
  } else if (const auto* f = std::get_if<ports::FlatPort>(&port.shape)) {
    const Eigen::Vector3d n = f->normal.normalized();
    h.model = "FLATPORT";
    h.params = {n.x(), n.y(), n.z(), (f->inner_point_mm - origin).dot(n) / 1000.0, f->thickness_mm / 1000.0,
                1.0, n_glass, n_water};
  } else {
    throw InvalidInput(field, fmt::format("refractive COLMAP and calibmar have no {} port (FLATPORT, DOMEPORT only)",
                                          port.KindName()));
  }
  return h;
}

std::string HousingSigmaToml(const RefractiveHousing& h) {
  const auto& sg = h.sigma;
  const double na = h.params[5];
  std::string out;
  const auto scalar = [&](std::string_view key, double v) {
    if (std::isfinite(v)) out += fmt::format("{} = {}\n", key, ShortNum(v));
  };
  const auto vector = [&](std::string_view key, double scale) {
    if (std::isfinite(sg[0]) && std::isfinite(sg[1]) && std::isfinite(sg[2])) {
      out += fmt::format("{} = [{}, {}, {}]\n", key, ShortNum(scale * sg[0]), ShortNum(scale * sg[1]), ShortNum(scale * sg[2]));
    }
  };
  if (h.model == "DOMEPORT") {
    vector("center_mm", 1000);
    scalar("inner_radius_mm", 1000 * sg[3]);
  } else {
    vector("normal", 1);
    scalar("distance_mm", 1000 * sg[3]);
  }
  scalar("thickness_mm", 1000 * sg[4]);
  scalar("n_glass", sg[6] / na);  // na's own σ is not carried: porthole's housing air is n = 1
  scalar("n_water", sg[7] / na);
  if (out.empty()) return "";
  return "\n# 1 sigma of the " + h.model + " housing as the input file gives it (calibmar's # non_svp_est_std_dev),\n"
         "# in this file's units; porthole's optics do not use it (docs/interop.md)\n[sigma]\n" + out;
}

}  // namespace porthole::interop
