#include "porthole/housing/housed.h"

#include <fmt/format.h>

#include <cmath>
#include <limits>

#include "porthole/core/error.h"
#include "porthole/ports/virtual_image.h"

namespace porthole::housing {
namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();
}  // namespace

void Validate(const HousedCamera& h) {
  lens::Validate(h.lens, "lens");
  lens::Validate(h.camera, "camera");
  if (h.lens.mount != h.camera.mount) {
    throw InvalidInput("lens", fmt::format("{} is a {} lens, the {} has a {} mount", h.lens.name, h.lens.mount,
                                           h.camera.name, h.camera.mount));
  }
  if (!h.ep_offset_mm.allFinite()) throw InvalidInput("ep_offset_mm", "must be three finite numbers");
  if (h.ep_in_housing_mm && !h.ep_in_housing_mm->allFinite()) {
    throw InvalidInput("ep_in_housing_mm", "must be three finite numbers");
  }
}

const lens::Mount& MountOf(const HousedCamera& h) { return lens::MountByName(h.camera.mount); }

Vec3 NominalPupilAtFocus(const HousedCamera& h, double fd_mm) {
  if (h.ep_in_housing_mm) return *h.ep_in_housing_mm;
  Vec3 ep = h.port.default_ep_in_housing_mm;
  ep.z() = h.lens.PupilToFlangeMm(fd_mm);
  return ep;
}

ports::PortSystem SystemAtFocus(const HousedCamera& h, double fd_mm) {
  const Vec3 nominal = NominalPupilAtFocus(h, fd_mm);
  if (h.ep_offset_mm.isZero(0)) return ports::MakeSystem(h.port, h.env, nominal);
  // A cam-frame port is centred on the lens's own pupil; the offset then moves the pupil within it.
  ports::PortSpec port = h.port;
  if (port.frame == ports::PortFrame::kCam) port = ports::Place(port, nominal, 1.5, 1.34).spec;  // geometry only
  return ports::MakeSystem(port, h.env, nominal + h.ep_offset_mm);
}

Focused SolveFocus(const HousedCamera& h, const std::function<double(const ports::PortSystem&)>& required) {
  const lens::Mount& mount = MountOf(h);
  const lens::LensSpec& ln = h.lens;
  double fd_used = kInf;
  Focused out{SystemAtFocus(h, fd_used), {}};
  std::optional<double> fd;
  double d = 0;
  for (int it = 0; it < 100; ++it) {
    d = required(out.sys);
    fd = lens::FocusForSubjectMm(ln, mount, d);
    const double next = fd.value_or(ln.min_focus_mm);
    const double moved = std::abs(ln.PupilToFlangeMm(next) - ln.PupilToFlangeMm(fd_used));
    fd_used = next;
    out.sys = SystemAtFocus(h, fd_used);
    if (moved < 1e-10 || h.ep_in_housing_mm) break;
  }
  FocusSetting& f = out.focus;
  f.d_s2ep_mm = required(out.sys);
  f.focus_distance_mm = lens::FocusForSubjectMm(ln, mount, f.d_s2ep_mm);
  f.ep_to_flange_mm = ln.PupilToFlangeMm(f.focus_distance_mm.value_or(ln.min_focus_mm));
  f.ep_in_housing_mm = out.sys.ep_in_housing_mm;
  if (!f.focus_distance_mm && std::isfinite(f.d_s2ep_mm)) {
    const double closest = lens::SubjectToPupilMm(ln, mount, ln.min_focus_mm);
    f.closeup_dioptre = std::max(0.0, 1000.0 / f.d_s2ep_mm - 1000.0 / closest);
  }
  return out;
}

Focused FocusOnSubject(const HousedCamera& h, double subject_mm) {
  RequirePositive("subject_distance_mm", subject_mm);
  Validate(h);
  const Focused f = SolveFocus(h, [&](const ports::PortSystem& sys) {
    const double wd = subject_mm - PupilToOuterMm(sys);
    if (!(wd > 0)) {
      throw InvalidInput("subject_distance_mm", fmt::format("the object lies inside the port ({:.1f} mm from the "
                                                            "pupil, its outer surface {:.1f} mm)",
                                                            subject_mm, PupilToOuterMm(sys)));
    }
    return ports::ParaxialVirtualImage(sys, wd).d_s2ep_mm;
  });
  if (!f.focus.focus_distance_mm) {
    const lens::Mount& mount = MountOf(h);
    throw InvalidInput("subject_distance_mm",
                       fmt::format("the virtual image of an object {:.0f} mm away is {:.1f} mm from the pupil; the "
                                   "{} focuses no closer than {:.1f} mm",
                                   subject_mm, f.focus.d_s2ep_mm, h.lens.name,
                                   lens::SubjectToPupilMm(h.lens, mount, h.lens.min_focus_mm)));
  }
  return f;
}

double PupilToOuterMm(const ports::PortSystem& sys) { return sys.OuterVertexZ() - sys.ep_in_housing_mm.z(); }

std::optional<Vec3> ChiefRay(const lens::LensSpec& lens, double c_mm, double x_mm, double y_mm) {
  if (lens.projection == camera::Projection::kRectilinear) return Vec3(x_mm, -y_mm, c_mm).normalized();
  const double r = std::hypot(x_mm, y_mm);
  const auto theta = lens::FieldAngleRad(lens, c_mm, r);
  if (!theta || !(*theta < camera::MaxFieldAngleRad(lens.projection))) return std::nullopt;
  if (r == 0) return Vec3(0, 0, 1);
  const double s = std::sin(*theta) / r;
  return Vec3(s * x_mm, -s * y_mm, std::cos(*theta));
}

}  // namespace porthole::housing
