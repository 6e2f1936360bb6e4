#include "porthole/render/render.h"

#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <mutex>
#include <numbers>
#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "porthole/core/error.h"
#include "porthole/core/input.h"
#include "porthole/catalogue/presets.h"
#include "porthole/optics/batch.h"
#include "porthole/render/dots.h"

namespace porthole::render {
namespace {

using Vec3 = Eigen::Vector3d;
using Vec2 = Eigen::Vector2d;
constexpr double kInf = std::numeric_limits<double>::infinity();

Eigen::Matrix3d RotX(double a) { return Eigen::AngleAxisd(a, Vec3::UnitX()).toRotationMatrix(); }
Eigen::Matrix3d RotY(double a) { return Eigen::AngleAxisd(a, Vec3::UnitY()).toRotationMatrix(); }
Eigen::Matrix3d RotZ(double a) { return Eigen::AngleAxisd(a, Vec3::UnitZ()).toRotationMatrix(); }
double Rad(double deg) { return deg * std::numbers::pi / 180; }

// splitmix64: a counter-based generator, so each pixel's samples depend on (seed, pixel) alone and
// the image is the same on any number of threads.
struct Rng {
  std::uint64_t state;
  std::uint64_t Next() {
    std::uint64_t z = (state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  double Uniform() { return static_cast<double>(Next() >> 11) * 0x1.0p-53; }  // [0, 1)
};

// sin and cos on [−π/4, π/4] by their Taylor series to x⁹ and x¹⁰ (error < 4e-10): the disc
// samples need no more, and libm's sincos was an eighth of the render's time.
void SinCosQuarter(double x, double* s, double* c) {
  const double x2 = x * x;
  *s = x * (1 + x2 * (-1.0 / 6 + x2 * (1.0 / 120 + x2 * (-1.0 / 5040 + x2 * (1.0 / 362880)))));
  *c = 1 + x2 * (-0.5 + x2 * (1.0 / 24 + x2 * (-1.0 / 720 + x2 * (1.0 / 40320 - x2 / 3628800))));
}

// Shirley–Chiu concentric map of the unit square onto the unit disc (area-preserving, keeps strata).
Vec2 ConcentricDisc(double a, double b) {
  a = 2 * a - 1;
  b = 2 * b - 1;
  if (a == 0 && b == 0) return Vec2::Zero();
  constexpr double kQuarter = std::numbers::pi / 4;
  double s = 0, c = 0;
  if (std::abs(a) > std::abs(b)) {
    SinCosQuarter(kQuarter * b / a, &s, &c);
    return a * Vec2(c, s);
  }
  SinCosQuarter(kQuarter * a / b, &s, &c);  // angle π/2 − x: (sin x, cos x)
  return b * Vec2(s, c);
}

int ChannelOf(double lambda_nm, ColorMode color) {
  if (color == ColorMode::kGrey) return 0;
  return lambda_nm < 500 ? 2 : lambda_nm < 590 ? 1 : 0;
}

// The target plane in the housing frame: origin (the target frame's), and the rotation.
struct Plane {
  Vec3 origin_in_housing;
  Eigen::Matrix3d rotation;  // columns: target X, Y, Z in housing axes
  Vec3 normal() const { return rotation.col(2); }
};
Plane TargetPlane(const Setup& s, const Pose& pose) { return {s.ep_in_housing_mm + pose.translation_mm, pose.rotation}; }

// Where a ray (housing frame) meets the target plane, in board coordinates; nullopt when it runs
// parallel to the plane or away from it.
std::optional<Vec2> BoardHit(const Plane& plane, const optics::Ray& ray) {
  const Vec3 n = plane.normal();
  const double denom = ray.dir.dot(n);
  if (!(std::abs(denom) > 1e-15)) return std::nullopt;
  const double t = (plane.origin_in_housing - ray.origin).dot(n) / denom;
  if (!(t > 0)) return std::nullopt;
  const Vec3 local = plane.rotation.transpose() * (ray.origin + t * ray.dir - plane.origin_in_housing);
  return Vec2(local.x(), local.y());
}

// The chief ray of pixel uv through the band's port, on the board.
std::optional<Vec2> ChiefOnBoard(const Setup& s, const Band& band, const Plane& plane, const Vec2& uv) {
  const auto d = s.camera.Unproject(uv);
  if (!d) return std::nullopt;
  optics::Ray out;
  if (optics::TraceSequence<double>(band.outward, optics::Ray{s.ep_in_housing_mm, *d}, &out) != optics::RayStatus::kOk) {
    return std::nullopt;
  }
  return BoardHit(plane, out);
}

std::string Px(const Vec2& uv) { return fmt::format("({:.1f}, {:.1f}) px", uv.x(), uv.y()); }

}  // namespace

Pose Compose(const Pose& a_from_b, const Pose& b_from_c) {
  Pose p;
  p.rotation = a_from_b.rotation * b_from_c.rotation;
  p.translation_mm = a_from_b.rotation * b_from_c.translation_mm + a_from_b.translation_mm;
  return p;
}

Eigen::Vector3d TargetCentre(const calib::TargetSpec& target) {
  Vec3 c = Vec3::Zero();
  const auto pts = calib::TargetPoints(target);
  int n = 0;
  const std::vector<bool> has = calib::TargetPointMask(target);
  for (std::size_t i = 0; i < pts.size(); ++i) {
    if (i >= has.size() || !has[i]) continue;  // coded: ids that are no target
    c += pts[i];
    ++n;
  }
  return c / std::max(1, n);
}

Pose PoseFacing(const calib::TargetSpec& target, double distance_mm, const Eigen::Vector2d& shift_mm, double tilt_x_deg,
                double tilt_y_deg, double roll_deg) {
  Pose p;
  p.rotation = RotZ(Rad(roll_deg)) * RotY(Rad(tilt_y_deg)) * RotX(Rad(tilt_x_deg));
  p.translation_mm = Vec3(shift_mm.x(), shift_mm.y(), distance_mm) - p.rotation * TargetCentre(target);
  return p;
}

void Validate(const RenderOptions& o) {
  const int m = static_cast<int>(std::lround(std::sqrt(static_cast<double>(o.samples_per_pixel))));
  if (o.samples_per_pixel < 1 || m * m != o.samples_per_pixel || m > 64) {
    throw InvalidInput("samples_per_pixel", "must be a square number from 1 to 4096 (1, 4, 9, 16, ...)");
  }
  const int m2 = static_cast<int>(std::lround(std::sqrt(static_cast<double>(o.edge_samples_per_pixel))));
  if (o.edge_samples_per_pixel < 0 || m2 * m2 != o.edge_samples_per_pixel || m2 > 64) {
    throw InvalidInput("edge_samples_per_pixel", "must be 0 (off) or a square number up to 4096 (64, 256, ...)");
  }
  if (!(std::isfinite(o.exposure) && o.exposure > 0)) throw InvalidInput("exposure", "must be a number > 0");
  if (o.threads < 0) throw InvalidInput("threads", "must be >= 0");
  if (!(std::isfinite(o.full_well_e) && o.full_well_e >= 0)) throw InvalidInput("full_well_e", "must be a number >= 0");
  if (!(std::isfinite(o.read_noise_e) && o.read_noise_e >= 0)) throw InvalidInput("read_noise_e", "must be a number >= 0");
}

Setup Resolve(const Scene& scene, ColorMode color) {
  housing::HousedCamera h = scene.housed;
  if (scene.medium == Medium::kAir || scene.bare) h.env.water_index = 1.0;
  housing::Validate(h);
  if (!(scene.f_number > 0)) throw InvalidInput("f_number", "must be > 0 (inf: a pinhole)");
  if (scene.bands_nm.empty()) throw InvalidInput("bands_nm", "needs at least one wavelength");
  for (double l : scene.bands_nm) {
    if (!(std::isfinite(l) && l > 0)) throw InvalidInput("bands_nm", "wavelengths must be numbers > 0 (nm)");
  }
  const std::size_t n_points = scene.target.kind == calib::TargetKind::kCoded && !scene.target.field.empty()
                                   ? scene.target.field.size()
                                   : scene.target.kind == calib::TargetKind::kCoded
                                         ? static_cast<std::size_t>(std::max(0, scene.target.NumPoints()))
                                         : std::size_t(std::max(0, scene.target.PointCols())) *
                                               std::size_t(std::max(0, scene.target.PointRows()));
  if (n_points > kMaxTargetPoints) {
    throw InvalidInput("target", fmt::format("{} has {} points, more than the limit of {} points for a rendered "
                                             "target", scene.target.ToString(), n_points, kMaxTargetPoints));
  }

  Setup s;
  if (scene.focus_distance_mm) {
    const double fd = *scene.focus_distance_mm;
    if (!(fd > 0)) throw InvalidInput("focus_distance_mm", "must be > 0 (mm, or inf)");
    if (fd < h.lens.min_focus_mm) {
      throw InvalidInput("focus_distance_mm", fmt::format("the {} focuses no closer than {:g} mm", h.lens.name,
                                                          h.lens.min_focus_mm));
    }
    s.system = housing::SystemAtFocus(h, fd);
    s.focus.focus_distance_mm = fd;
    s.focus.d_s2ep_mm = lens::SubjectToPupilMm(h.lens, housing::MountOf(h), fd);
    s.focus.ep_to_flange_mm = h.lens.PupilToFlangeMm(fd);
    s.focus.ep_in_housing_mm = s.system.ep_in_housing_mm;
  } else {
    const double subject = scene.pose.Apply(TargetCentre(scene.target)).z();
    if (!(subject > 0)) throw InvalidInput("pose", "the target's centre lies behind the camera");
    const housing::Focused f = !scene.bare ? housing::FocusOnSubject(h, subject) : [&] {
      // The lens alone: it focuses on the target itself.
      housing::Focused g = housing::SolveFocus(h, [&](const ports::PortSystem&) { return subject; });
      if (!g.focus.focus_distance_mm) {
        throw InvalidInput("subject_distance_mm", fmt::format("the {} focuses no closer than {:g} mm (the target's "
                                                              "centre is {:.0f} mm from the pupil)",
                                                              h.lens.name, h.lens.min_focus_mm, subject));
      }
      return g;
    }();
    s.system = f.sys;
    s.focus = f.focus;
    s.focused_on_target = true;
    s.focus_subject_mm = subject;
  }
  s.ep_in_housing_mm = s.system.ep_in_housing_mm;
  s.pupil_radius_mm = std::isinf(scene.f_number) ? 0.0 : h.lens.focal_length_mm / (2 * scene.f_number);

  if (scene.camera) {
    s.camera = *scene.camera;
    camera::ValidateCamera(s.camera, "camera");
  } else {
    const double c = scene.c_mm ? RequirePositive("c_mm", *scene.c_mm)
                     : std::isinf(s.focus.d_s2ep_mm)
                         ? h.lens.focal_length_mm
                         : lens::PrincipalDistanceMm(h.lens.focal_length_mm, s.focus.d_s2ep_mm);
    const camera::Sensor& sensor = h.camera.sensor;
    using camera::CameraModelId;
    using camera::Projection;
    CameraModelId model = CameraModelId::kBrown;
    switch (h.lens.projection) {
      case Projection::kRectilinear: model = CameraModelId::kBrown; break;
      case Projection::kEquidistant: model = CameraModelId::kEquidistant; break;
      case Projection::kEquisolid: model = CameraModelId::kEquisolid; break;
      case Projection::kStereographic: model = CameraModelId::kStereographic; break;
      case Projection::kOrthographic: model = CameraModelId::kOrthographic; break;
    }
    s.camera = camera::Camera::Ideal(model, sensor, c / sensor.pixel_pitch_mm);
  }

  // Bounds on memory and time (docs/robustness.md): the frame is allocated whole, about 19 bytes
  // a pixel value at worst (4 for the float image, up to 8 for the pixels to refine, 1 for the
  // refinement flags, 2 each for the 16-bit image, its PNG and the PNG's copy): 64 million values
  // stay near 1.2 GB.
  const int channels = color == ColorMode::kRgb ? 3 : 1;
  const double frame_px = double(s.camera.sensor.width_px) * double(s.camera.sensor.height_px);
  if (frame_px * channels > kMaxFrameValues) {
    throw InvalidInput("frame", fmt::format("{} x {} px{} ({:.0f} million pixel values) is more than the limit of {:g} "
                                            "million pixel values (pixels x channels) for a rendered frame (the camera's "
                                            "sensor)",
                                            s.camera.sensor.width_px, s.camera.sensor.height_px,
                                            channels == 3 ? " RGB" : "", frame_px * channels / 1e6, kMaxFrameValues / 1e6));
  }

  for (double k : scene.vignetting_pa) {
    if (!std::isfinite(k)) throw InvalidInput("vignetting_pa", "must be three finite numbers k1,k2,k3");
  }
  for (int i = 0; i <= 100; ++i) {  // 1 + k1 r² + k2 r⁴ + k3 r⁶ > 0 from the centre to the corners
    const double r2 = (i / 100.0) * (i / 100.0);
    const auto& k = scene.vignetting_pa;
    if (!(1 + r2 * (k[0] + r2 * (k[1] + r2 * k[2])) > 0)) {
      throw InvalidInput("vignetting_pa", "1 + k1 r^2 + k2 r^4 + k3 r^6 must stay > 0 from the frame's centre (r = 0) "
                                          "to its corners (r = 1)");
    }
  }

  bool has[3] = {false, false, false};
  for (double l : scene.bands_nm) {
    ports::Environment env = h.env;
    env.conditions.lambda_nm = l;
    Band b;
    b.lambda_nm = l;
    b.channel = ChannelOf(l, color);
    if (!scene.bare) {  // bare: no interfaces, the rays leave the pupil unbent (indices 1)
      b.n_glass = env.GlassIndex(s.system.spec.material());
      b.n_water = env.WaterIndex();
      b.outward = ports::Place(s.system.spec, s.ep_in_housing_mm, b.n_glass, b.n_water).Outward();
    }
    has[b.channel] = true;
    s.bands.push_back(std::move(b));
  }
  if (color == ColorMode::kRgb && !(has[0] && has[1] && has[2])) {
    throw InvalidInput("bands_nm", "RGB needs a band in each channel: blue < 500 nm, green 500-590 nm, red >= 590 nm");
  }
  return s;
}

namespace {
// Solid angle per pixel area of the camera's unprojection at uv (sr/px²), central differences of
// the unit rays over ±0.5 px; nullopt where a ray is missing.
std::optional<double> SolidAnglePerPixel(const camera::Camera& camera, const Vec2& uv, Vec3* ray) {
  constexpr double kH = 0.5;
  const auto d0 = camera.Unproject(uv);
  const auto du0 = camera.Unproject(uv - Vec2(kH, 0)), du1 = camera.Unproject(uv + Vec2(kH, 0));
  const auto dv0 = camera.Unproject(uv - Vec2(0, kH)), dv1 = camera.Unproject(uv + Vec2(0, kH));
  if (!d0 || !du0 || !du1 || !dv0 || !dv1) return std::nullopt;
  *ray = d0->normalized();
  const Vec3 du = (du1->normalized() - du0->normalized()) / (2 * kH);
  const Vec3 dv = (dv1->normalized() - dv0->normalized()) / (2 * kH);
  return std::abs(du.cross(dv).dot(*ray));
}
}  // namespace

double VignettingAt(const Scene& scene, const camera::Camera& camera, const Eigen::Vector2d& uv) {
  double v = 1;
  if (scene.natural_vignetting) {
    Vec3 ray, axis;
    const auto here = SolidAnglePerPixel(camera, uv, &ray);
    const auto centre = SolidAnglePerPixel(camera, camera.PrincipalPointPx(), &axis);
    if (!here || !centre || !(*centre > 0)) return 0;
    v *= std::max(0.0, ray.z()) * *here / *centre;
  }
  const auto& k = scene.vignetting_pa;
  if (k[0] != 0 || k[1] != 0 || k[2] != 0) {
    const camera::Sensor& s = camera.sensor;
    const Vec2 mid(0.5 * (s.width_px - 1), 0.5 * (s.height_px - 1));
    const double r2 = (uv - mid).squaredNorm() / mid.squaredNorm();
    v *= 1 + r2 * (k[0] + r2 * (k[1] + r2 * k[2]));
  }
  return v;
}

std::optional<Eigen::Vector2d> ProjectThroughPort(const Setup& s, const Band& band, const Pose& pose,
                                                  const Eigen::Vector3d& point_in_target_mm) {
  Plane plane = TargetPlane(s, pose);  // the point's own plane Z = z
  plane.origin_in_housing += point_in_target_mm.z() * plane.normal();
  const Vec2 goal = point_in_target_mm.head<2>();
  auto residual = [&](const Vec2& uv) -> std::optional<Vec2> {
    const auto hit = ChiefOnBoard(s, band, plane, uv);
    if (!hit) return std::nullopt;
    return Vec2(*hit - goal);
  };
  // Start: the point seen without the port; else the principal point.
  Vec2 uv = s.camera.Project(pose.Apply(point_in_target_mm)).value_or(s.camera.PrincipalPointPx());
  auto r = residual(uv);
  if (!r) {
    uv = s.camera.PrincipalPointPx();
    r = residual(uv);
    if (!r) return std::nullopt;
  }
  constexpr double kH = 1e-4;  // px, central differences
  for (int it = 0; it < 60; ++it) {
    if (r->norm() < 1e-10) return uv;
    Eigen::Matrix2d jac;
    for (int k = 0; k < 2; ++k) {
      Vec2 e = Vec2::Zero();
      e[k] = kH;
      const auto a = residual(uv + e), b = residual(uv - e);
      if (!a || !b) return std::nullopt;
      jac.col(k) = (*a - *b) / (2 * kH);
    }
    const Vec2 step = jac.fullPivLu().solve(*r);
    if (!step.allFinite()) return std::nullopt;
    // Damped: halve the step until the residual shrinks (rays beyond a rim fail).
    double scale = 1;
    bool moved = false;
    for (int k = 0; k < 30; ++k, scale *= 0.5) {
      const Vec2 next = uv - scale * step;
      const auto rn = residual(next);
      if (rn && rn->norm() < r->norm()) {
        uv = next;
        r = rn;
        moved = true;
        break;
      }
    }
    if (!moved || scale * step.norm() < 1e-11) break;
  }
  if (r->norm() < 1e-7) return uv;
  return std::nullopt;
}

namespace {
// Whether the chief ray of pixel uv (band) meets the target's surfaces first at `point` (target
// frame): no surface nearer the camera hides it.
bool SeenAt(const Setup& s, const Band& band, const Pose& pose, const Surfaces& surfaces, const Vec3& point,
            const Vec2& uv) {
  const auto d = s.camera.Unproject(uv);
  if (!d) return false;
  optics::Ray out;
  if (optics::TraceSequence<double>(band.outward, optics::Ray{s.ep_in_housing_mm, *d}, &out) != optics::RayStatus::kOk) {
    return false;
  }
  const Plane plane = TargetPlane(s, pose);
  const Eigen::Matrix3d to_target = plane.rotation.transpose();
  double value = 0, t = 0;
  Vec2 hit;
  const int level = FirstHit(surfaces, to_target * (out.origin - plane.origin_in_housing), to_target * out.dir, 0,
                             &value, &t, &hit);
  return level >= 0 && std::abs(surfaces.z_mm[level] - point.z()) < 1e-9 && (hit - point.head<2>()).norm() < 1e-6;
}
}  // namespace

std::vector<TruthPoint> GroundTruth(const Scene& scene, const Setup& s, LeftOut* left_out) {
  const auto pts = calib::TargetPoints(scene.target);
  const Extent e = BoardExtent(scene.target, scene.style);
  std::vector<bool> has = calib::TargetPointMask(scene.target);  // coded: ids that are no target
  has.resize(pts.size(), false);
  std::vector<Vec3> check = {Vec3(e.x_min, e.y_min, 0), Vec3(e.x_max, e.y_min, 0), Vec3(e.x_min, e.y_max, 0),
                             Vec3(e.x_max, e.y_max, 0)};
  for (std::size_t i = 0; i < pts.size(); ++i) {
    if (has[i]) check.push_back(pts[i]);
  }
  for (const Vec3& p : check) {
    const Vec3 c = scene.pose.Apply(p);
    if (!(c.z() > 0)) {
      throw InvalidInput("pose", fmt::format("the target lies behind the camera (its point ({:g}, {:g}, {:g}) mm at z = "
                                             "{:.1f} mm from the pupil)", p.x(), p.y(), p.z(), c.z()));
    }
    if (!scene.bare && s.system.InsideOuterSurface(c + s.ep_in_housing_mm)) {
      throw InvalidInput("pose", fmt::format("the target reaches into the port (its point ({:g}, {:g}, {:g}) mm at "
                                             "{:.1f} mm from the pupil)", p.x(), p.y(), p.z(), c.norm()));
    }
  }
  const camera::Sensor& sensor = s.camera.sensor;
  auto in_frame = [&](const Vec2& uv) {
    return uv.x() >= 0 && uv.y() >= 0 && uv.x() <= sensor.width_px - 1 && uv.y() <= sensor.height_px - 1;
  };
  // Coded targets are read one by one: a target is kept when it images whole and unhidden.
  const bool coded = scene.target.kind == calib::TargetKind::kCoded;
  const Surfaces surfaces = coded ? MakeSurfaces(scene.target, scene.style) : Surfaces{};
  LeftOut dropped;
  std::vector<TruthPoint> out;
  for (std::size_t i = 0; i < pts.size(); ++i) {
    if (!has[i]) continue;
    TruthPoint tp;
    tp.id = static_cast<int>(i);
    tp.point_in_target_mm = pts[i];
    tp.point_in_cam_mm = scene.pose.Apply(pts[i]);
    bool partial = false, hidden = false;
    const double frame_mm = coded ? FrameRadiusMm(scene.target, tp.id) : 0;
    const double seen_mm = coded ? SeenRadiusMm(scene.target, tp.id) : 0;
    for (const Band& b : s.bands) {
      const auto uv = ProjectThroughPort(s, b, scene.pose, pts[i]);
      if (coded) {
        // The centre and 32 points round each of two circles: the band round the ring must image
        // inside the frame (frame_mm), and the chief ray of the ring's outer edge (seen_mm) meet
        // this target first. A plate is larger than a ring, so what hides part of the ring crosses
        // that edge.
        constexpr int kRim = 32;
        for (int k = -1; k < 2 * kRim && uv && !partial; ++k) {
          const double a = k * 2 * std::numbers::pi / kRim, rad = k < kRim ? frame_mm : seen_mm;
          const Vec3 p = k < 0 ? pts[i] : Vec3(pts[i] + rad * Vec3(std::cos(a), std::sin(a), 0));
          const auto q = k < 0 ? uv : ProjectThroughPort(s, b, scene.pose, p);
          if (!q || (k < kRim && !in_frame(*q))) partial = true;
          else if (k < 0 || k >= kRim) hidden = hidden || !SeenAt(s, b, scene.pose, surfaces, p, *q);
        }
        if (!uv || partial) {
          partial = true;
          break;
        }
        tp.pixel_per_band.push_back(*uv);
        continue;
      }
      if (!uv) {
        const auto direct = s.camera.Project(tp.point_in_cam_mm);
        if (!(direct && in_frame(*direct))) {
          throw InvalidInput("pose", fmt::format("the target falls outside the camera's field (point {})", i));
        }
        throw InvalidInput("port", fmt::format("no ray from target point {} passes the port at {:g} nm (beyond its rim, "
                                               "or totally reflected)", i, b.lambda_nm));
      }
      if (!in_frame(*uv)) {
        throw InvalidInput("pose", fmt::format("the target falls outside the image: point {} images at {} in a {}x{} "
                                               "frame", i, Px(*uv), sensor.width_px, sensor.height_px));
      }
      tp.pixel_per_band.push_back(*uv);
    }
    if (partial) dropped.partial.push_back(tp.id);
    else if (hidden) dropped.occluded.push_back(tp.id);
    else out.push_back(std::move(tp));
  }
  if (coded && out.empty()) {
    throw InvalidInput("pose", fmt::format("no coded target images whole and unhidden inside the {}x{} frame ({} cut by "
                                           "the frame or beyond the port, {} hidden)", sensor.width_px, sensor.height_px,
                                           dropped.partial.size(), dropped.occluded.size()));
  }
  if (left_out) *left_out = std::move(dropped);
  return out;
}

Rendered Render(const Scene& scene, const RenderOptions& o) {
  const auto t0 = std::chrono::steady_clock::now();
  Validate(o);
  Rendered r;
  r.setup = Resolve(scene, o.color);
  const Setup& s = r.setup;
  r.truth = GroundTruth(scene, s, &r.left_out);
  {  // The image centre's chief ray must leave the housing in every band.
    const Vec2 centre((s.camera.sensor.width_px - 1) / 2.0, (s.camera.sensor.height_px - 1) / 2.0);
    const auto d = s.camera.Unproject(centre);
    for (const Band& b : s.bands) {
      optics::Ray out;
      if (!d || optics::TraceSequence<double>(b.outward, optics::Ray{s.ep_in_housing_mm, *d}, &out) !=
                    optics::RayStatus::kOk) {
        throw InvalidInput("port", fmt::format("the ray through the image centre cannot pass the port at {:g} nm", b.lambda_nm));
      }
    }
  }
  const Surfaces surfaces = MakeSurfaces(scene.target, scene.style);
  // One plane (every target but a coded field with raised targets): the ray meets the board, whose
  // reflectance is read directly — the path every other target takes, without FirstHit's levels.
  const bool flat = surfaces.z_mm.size() == 1 && surfaces.z_mm[0] == 0;
  const Reflectance reflect = flat ? MakeReflectance(scene.target, scene.style) : Reflectance{};
  const Plane plane = TargetPlane(s, scene.pose);
  const Vec3 plane_n = plane.normal();
  const int W = s.camera.sensor.width_px, H = s.camera.sensor.height_px;
  const int channels = o.color == ColorMode::kRgb ? 3 : 1;
  const std::size_t n_pixels = static_cast<std::size_t>(W) * H;
  r.image.width = W;
  r.image.height = H;
  r.image.channels = channels;
  r.image.data.assign(n_pixels * channels, 0.0f);  // first the mean reflectance, then the pixel value
  int bands_in[3] = {0, 0, 0};
  for (const Band& b : s.bands) ++bands_in[b.channel];
  const std::size_t n_bands = s.bands.size();

  const double focus_s = s.focus.d_s2ep_mm;
  const bool fisheye = s.camera.info().caps.fisheye;
  const bool pinhole = s.pupil_radius_mm == 0;
  const Vec3 ep = s.ep_in_housing_mm;
  const Eigen::Matrix3d board_from_housing = plane.rotation.transpose();

  // Shades the pixels `pixels` (indices v·W + u) with n = m² samples each, writes each pixel's mean
  // reflectance per channel into the image, and its "mixed" flag (its samples did not all see the
  // same value) when `mixed` is given; returns the number of blocked rays. `salt` 0 is the first
  // pass; the refinement draws other samples.
  auto shade = [&](const std::size_t* pixels, int np, int n, std::uint64_t salt, std::uint8_t* mixed) {
    const int m = static_cast<int>(std::lround(std::sqrt(static_cast<double>(n))));
    const std::size_t nr = static_cast<std::size_t>(np) * n;
    thread_local optics::RayBatch in, out;
    thread_local std::vector<int> perm;
    thread_local std::vector<double> sums, lo, hi;
    in.resize(nr);
    perm.resize(n);
    sums.assign(static_cast<std::size_t>(np) * n_bands, 0.0);
    lo.assign(np, kInf);
    hi.assign(np, -kInf);
    // Rays of every sample of the pixels, in the housing frame.
    camera::VisitModel(s.camera.model, [&](auto model) {
      using M = decltype(model);
      const double* params = s.camera.params.data();
      for (int p = 0; p < np; ++p) {
        const int u = static_cast<int>(pixels[p] % W), v = static_cast<int>(pixels[p] / W);
        Rng rng{(o.seed * 0xD1B54A32D192ED03ull ^ (static_cast<std::uint64_t>(v) * W + u)) + salt};
        for (int k = 0; k < n; ++k) perm[k] = k;
        for (int k = n - 1; k > 0; --k) std::swap(perm[k], perm[static_cast<int>(rng.Next() % (k + 1))]);
        for (int k = 0; k < n; ++k) {
          const std::size_t i = static_cast<std::size_t>(p) * n + k;
          const Vec2 uv(u - 0.5 + ((k % m) + rng.Uniform()) / m, v - 0.5 + ((k / m) + rng.Uniform()) / m);
          const auto d = M::template Unproject<double>(s.camera.sensor, params, uv);
          const int q = perm[k];
          const Vec2 a = s.pupil_radius_mm * ConcentricDisc(((q % m) + rng.Uniform()) / m, ((q / m) + rng.Uniform()) / m);
          bool ok = d.has_value();
          Vec3 origin = ep, dir = d.value_or(Vec3::UnitZ());
          if (ok && !pinhole) {
            const Vec3 at(a.x(), a.y(), 0);
            if (std::isinf(focus_s)) {
              origin = ep + at;
            } else if (fisheye) {
              origin = ep + at;
              dir = (focus_s * dir - at).normalized();
            } else if (dir.z() > 0) {
              origin = ep + at;
              dir = ((focus_s / dir.z()) * dir - at).normalized();
            } else {
              ok = false;
            }
          }
          in.ox[i] = origin.x();
          in.oy[i] = origin.y();
          in.oz[i] = origin.z();
          in.dx[i] = dir.x();
          in.dy[i] = dir.y();
          in.dz[i] = dir.z();
          in.status[i] = ok ? optics::RayStatus::kOk : optics::RayStatus::kMissed;
        }
      }
      return 0;
    });
    optics::BatchOptions bo;
    bo.num_threads = 1;
    long long blocked_here = 0;
    for (std::size_t bi = 0; bi < n_bands; ++bi) {
      optics::TraceBatch(s.bands[bi].outward, in, &out, bo);
      for (int p = 0; p < np; ++p) {
        double sum = 0, low = lo[p], high = hi[p];
        for (int k = 0; k < n; ++k) {
          const std::size_t i = static_cast<std::size_t>(p) * n + k;
          double value = 0;  // blocked by the housing
          if (out.status[i] != optics::RayStatus::kOk) {
            ++blocked_here;
          } else {
            const Vec3 o3(out.ox[i], out.oy[i], out.oz[i]), d3(out.dx[i], out.dy[i], out.dz[i]);
            if (flat) {
              const double t = (plane.origin_in_housing - o3).dot(plane_n) / d3.dot(plane_n);
              if (!(t > 0) || !std::isfinite(t)) {
                value = scene.style.background;
              } else {
                const Vec3 local = board_from_housing * (o3 + t * d3 - plane.origin_in_housing);
                value = reflect(local.x(), local.y());
              }
            } else {
              double t = 0;
              Vec2 hit;
              FirstHit(surfaces, board_from_housing * (o3 - plane.origin_in_housing), board_from_housing * d3,
                       scene.style.background, &value, &t, &hit);
            }
          }
          sum += value;
          low = std::min(low, value);
          high = std::max(high, value);
        }
        sums[static_cast<std::size_t>(p) * n_bands + bi] = sum / n;
        lo[p] = low;
        hi[p] = high;
      }
    }
    for (int p = 0; p < np; ++p) {
      double c[3] = {0, 0, 0};
      for (std::size_t bi = 0; bi < n_bands; ++bi) c[s.bands[bi].channel] += sums[p * n_bands + bi];
      float* px = r.image.data.data() + pixels[p] * channels;
      for (int ch = 0; ch < channels; ++ch) px[ch] = static_cast<float>(c[ch] / bands_in[ch]);
      if (mixed) mixed[pixels[p]] = hi[p] > lo[p];
    }
    return blocked_here;
  };

  // Pass 1: every pixel, rows cut into tiles of kTile pixels (~1000 rays, in cache through the
  // surfaces). Pass 2 (edge_samples_per_pixel): the pixels near an edge again, with more samples.
  const bool refine = o.edge_samples_per_pixel > o.samples_per_pixel;
  std::vector<std::uint8_t> mixed(refine ? n_pixels : 0);
  std::mutex progress_mutex;
  std::atomic<std::ptrdiff_t> done{0};
  auto report = [&](std::ptrdiff_t blocks, double from, double to) {
    const std::ptrdiff_t d = ++done;
    if (o.progress && (d % std::max<std::ptrdiff_t>(1, blocks / 20) == 0 || d == blocks)) {
      std::lock_guard<std::mutex> lock(progress_mutex);
      o.progress(from + (to - from) * static_cast<double>(d) / blocks);
    }
  };
  const double pass1_share = refine ? 0.3 : 1.0;  // of the progress reported
  constexpr int kTile = 64;
  const int tiles_per_row = (W + kTile - 1) / kTile;
  const std::ptrdiff_t blocks = static_cast<std::ptrdiff_t>(tiles_per_row) * H;
  std::atomic<long long> blocked{0};
  optics::ParallelBlocks(o.threads, blocks, [&](std::ptrdiff_t block) {
    const int v = static_cast<int>(block / tiles_per_row);
    const int u0 = static_cast<int>(block % tiles_per_row) * kTile;
    const int np = std::min(W, u0 + kTile) - u0;
    std::size_t pixels[kTile];
    for (int p = 0; p < np; ++p) pixels[p] = static_cast<std::size_t>(v) * W + u0 + p;
    blocked += shade(pixels, np, o.samples_per_pixel, 0, refine ? mixed.data() : nullptr);
    report(blocks, 0, pass1_share);
  });
  r.blocked_fraction = static_cast<double>(blocked.load()) / (static_cast<double>(n_pixels) * o.samples_per_pixel * n_bands);

  if (refine) {
    // A pixel is refined when a pixel of its 3 × 3 neighbourhood (itself included) saw more than
    // one value, or holds a different value from its own: an edge crosses it or passes within a
    // pixel, even where the first samples missed a sliver of it.
    std::vector<std::size_t> todo;
    for (int v = 0; v < H; ++v) {
      for (int u = 0; u < W; ++u) {
        const float* c = r.image.data.data() + (static_cast<std::size_t>(v) * W + u) * channels;
        bool edge = false;
        for (int dv = -1; dv <= 1 && !edge; ++dv) {
          for (int du = -1; du <= 1 && !edge; ++du) {
            const int uu = u + du, vv = v + dv;
            if (uu < 0 || vv < 0 || uu >= W || vv >= H) continue;
            const std::size_t q = static_cast<std::size_t>(vv) * W + uu;
            edge = mixed[q] != 0;
            for (int ch = 0; ch < channels && !edge; ++ch) edge = r.image.data[q * channels + ch] != c[ch];
          }
        }
        if (edge) todo.push_back(static_cast<std::size_t>(v) * W + u);
      }
    }
    const int n2 = o.edge_samples_per_pixel;
    const int per_block = std::max(1, 1024 / n2);
    const std::ptrdiff_t blocks2 = (static_cast<std::ptrdiff_t>(todo.size()) + per_block - 1) / per_block;
    done = 0;
    optics::ParallelBlocks(o.threads, blocks2, [&](std::ptrdiff_t block) {
      const std::size_t begin = static_cast<std::size_t>(block) * per_block;
      const int np = static_cast<int>(std::min<std::size_t>(todo.size(), begin + per_block) - begin);
      shade(todo.data() + begin, np, n2, 0x5851F42D4C957F2Dull, nullptr);
      report(blocks2, pass1_share, 1);
    });
    r.refined_fraction = static_cast<double>(todo.size()) / n_pixels;
  }

  // Vignetting, exposure and sensor noise, per pixel (seeded by the pixel), a row at a time.
  const auto& pa = scene.vignetting_pa;
  const bool vignetting = scene.natural_vignetting || pa[0] != 0 || pa[1] != 0 || pa[2] != 0;
  optics::ParallelBlocks(o.threads, H, [&](std::ptrdiff_t v) {
    for (std::size_t i = static_cast<std::size_t>(v) * W; i < static_cast<std::size_t>(v + 1) * W; ++i) {
      Rng noise{~o.seed * 0xA0761D6478BD642Full ^ i};
      const double gain =
          vignetting ? VignettingAt(scene, s.camera, Vec2(static_cast<double>(i % W), static_cast<double>(v))) : 1.0;
      for (int ch = 0; ch < channels; ++ch) {
        float& px = r.image.data[i * channels + ch];
        double value = std::min(1.0, o.exposure * gain * px);
        if (o.full_well_e > 0) {  // Box–Muller pair: shot, read
          const double a = std::sqrt(-2 * std::log(1 - noise.Uniform())), b = 2 * std::numbers::pi * noise.Uniform();
          const double electrons = value * o.full_well_e;
          value = std::clamp((electrons + std::sqrt(electrons) * a * std::cos(b) + o.read_noise_e * a * std::sin(b)) /
                                 o.full_well_e, 0.0, 1.0);
        }
        px = static_cast<float>(value);
      }
    }
  });
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

std::string EncodePng(const Image& image, int bit_depth) {
  if (bit_depth != 8 && bit_depth != 16) throw InvalidInput("bit_depth", "must be 8 or 16");
  const int ch = image.channels;
  const int type = bit_depth == 8 ? CV_MAKETYPE(CV_8U, ch) : CV_MAKETYPE(CV_16U, ch);
  cv::Mat mat(image.height, image.width, type);
  const double full = bit_depth == 8 ? 255.0 : 65535.0;
  for (int v = 0; v < image.height; ++v) {
    for (int u = 0; u < image.width; ++u) {
      for (int c = 0; c < ch; ++c) {
        const int cv_c = ch == 3 ? 2 - c : c;  // OpenCV writes BGR
        const double x = std::clamp(static_cast<double>(image.at(u, v, c)), 0.0, 1.0) * full;
        if (bit_depth == 8) mat.ptr<unsigned char>(v)[u * ch + cv_c] = static_cast<unsigned char>(std::lround(x));
        else mat.ptr<unsigned short>(v)[u * ch + cv_c] = static_cast<unsigned short>(std::lround(x));
      }
    }
  }
  std::vector<unsigned char> buf;
  if (!cv::imencode(".png", mat, buf)) throw InternalError("PNG encoding failed");
  return std::string(buf.begin(), buf.end());
}

nlohmann::ordered_json TruthJson(const Scene& scene, const RenderOptions& o, const Rendered& r,
                                 const std::string& image_file, int bit_depth) {
  using Json = nlohmann::ordered_json;
  const Setup& s = r.setup;
  auto vec = [](const auto& v) {
    Json a = Json::array();
    for (int i = 0; i < v.size(); ++i) a.push_back(v[i]);
    return a;
  };
  auto length = [](double mm) { return std::isfinite(mm) ? Json(mm) : Json("inf"); };
  Json j;
  j["image"] = image_file;
  j["width_px"] = r.image.width;
  j["height_px"] = r.image.height;
  j["color"] = o.color == ColorMode::kRgb ? "rgb" : "grey";
  j["bit_depth"] = bit_depth;
  j["pixel_convention"] = "(0, 0) is the centre of the top-left pixel, u right, v down";
  j["target"] = scene.target.ToString();
  Json pose;
  pose["frame"] = "cam_from_target: point_in_cam = R point_in_target + t; cam = entrance pupil, housing axes";
  Json rot = Json::array();
  for (int i = 0; i < 3; ++i) rot.push_back(vec(Eigen::RowVector3d(scene.pose.rotation.row(i))));
  pose["rotation"] = rot;
  const Eigen::AngleAxisd aa(scene.pose.rotation);
  pose["rotation_deg"] = vec(Eigen::Vector3d(aa.axis() * aa.angle() * 180 / std::numbers::pi));
  pose["translation_mm"] = vec(scene.pose.translation_mm);
  j["pose"] = pose;
  Json cam;
  cam["model"] = std::string(s.camera.model_name());
  Json params;
  const auto& info = s.camera.info();
  for (int i = 0; i < info.num_params; ++i) params[std::string(info.params[i].json_key)] = s.camera.params[i];
  cam["camera"] = params;
  cam["sensor"] = {{"width_px", s.camera.sensor.width_px},
                   {"height_px", s.camera.sensor.height_px},
                   {"pixel_pitch_mm", s.camera.sensor.pixel_pitch_mm}};
  j["camera"] = cam;
  j["camera_body"] = scene.housed.camera.name;
  j["lens"] = {{"name", scene.housed.lens.name},
               {"focal_length_mm", scene.housed.lens.focal_length_mm},
               {"f_number", std::isinf(scene.f_number) ? Json("inf") : Json(scene.f_number)},
               {"pupil_radius_mm", s.pupil_radius_mm}};
  j["focus"] = {{"on", s.focused_on_target ? "target" : "focus_distance"},
                {"subject_distance_mm", s.focused_on_target ? Json(s.focus_subject_mm) : Json(nullptr)},
                {"focus_distance_mm", s.focus.focus_distance_mm ? length(*s.focus.focus_distance_mm) : Json(nullptr)},
                {"d_s2ep_mm", length(s.focus.d_s2ep_mm)},
                {"ep_in_housing_mm", vec(s.ep_in_housing_mm)}};
  j["port"] = scene.bare ? Json(nullptr) : Json{{"name", s.system.spec.name}, {"toml", catalogue::PortToToml(s.system.spec)}};
  j["medium"] = scene.medium == Medium::kWater && !scene.bare ? "water" : "air";
  const auto& env = scene.housed.env;
  j["water"] = {{"name", scene.medium == Medium::kWater && !scene.bare ? env.water : "air"},
                {"temperature_c", env.conditions.temperature_c},
                {"salinity_psu", env.conditions.salinity_psu},
                {"pressure_dbar", env.conditions.pressure_dbar}};
  Json bands = Json::array();
  const char* names[] = {"red", "green", "blue"};
  for (const Band& b : s.bands) {
    bands.push_back({{"lambda_nm", b.lambda_nm},
                     {"channel", o.color == ColorMode::kRgb ? names[b.channel] : "grey"},
                     {"n_glass", b.n_glass},
                     {"n_water", b.n_water}});
  }
  j["bands"] = bands;
  j["samples_per_pixel"] = o.samples_per_pixel;
  j["edge_samples_per_pixel"] = o.edge_samples_per_pixel > o.samples_per_pixel ? Json(o.edge_samples_per_pixel) : Json(nullptr);
  j["refined_fraction"] = r.refined_fraction;
  j["seed"] = o.seed;
  j["exposure"] = o.exposure;
  j["noise"] = o.full_well_e > 0 ? Json{{"full_well_e", o.full_well_e}, {"read_noise_e", o.read_noise_e}} : Json(nullptr);
  j["style"] = {{"black", scene.style.black}, {"white", scene.style.white}, {"background", scene.style.background}};
  j["vignetting"] = {{"natural", scene.natural_vignetting}, {"pa", Json::array({scene.vignetting_pa[0], scene.vignetting_pa[1], scene.vignetting_pa[2]})}};
  j["blocked_fraction"] = r.blocked_fraction;
  Json points = Json::array();
  for (const TruthPoint& tp : r.truth) {
    Json px = Json::array();
    for (const Vec2& uv : tp.pixel_per_band) px.push_back({uv.x(), uv.y()});
    points.push_back({{"id", tp.id},
                      {"target_mm", vec(tp.point_in_target_mm)},
                      {"cam_mm", vec(tp.point_in_cam_mm)},
                      {"px", px}});
  }
  j["points_note"] = "px: the point's image per band (the order of bands): its chief ray traced through the port";
  j["points"] = points;
  if (DotRadiusMm(scene.target) > 0) {  // circular targets: what an ellipse-centre detector measures (render/dots.h)
    j["dot_centres_note"] = "px: the centre of each dot's image per band (the ellipse fitted to its traced rim)";
    j["dot_centres"] = DotCentresJson(scene, s, r.truth);
  }
  if (scene.target.kind == calib::TargetKind::kCoded) {
    j["left_out_note"] = "coded targets not in points: partial (dot and ring not whole inside the frame), occluded "
                         "(hidden by a nearer surface)";
    j["left_out"] = {{"partial", r.left_out.partial}, {"occluded", r.left_out.occluded}};
  }
  return j;
}

namespace {
// Where a set's poses are drawn for several cameras (SetPosesSeenBy): ref_from_centre, and the
// largest distance between two of their pupils.
struct RigCentre {
  Pose ref_from_centre;
  double baseline_mm = 0;
};
RigCentre CentreOf(const std::vector<SetView>& views) {
  RigCentre c;
  if (views.size() < 2) return c;  // one camera: its own frame (the identity for SetPoses)
  std::vector<Vec3> pupils;
  Eigen::Matrix3d sum = Eigen::Matrix3d::Zero();
  for (const SetView& v : views) {
    pupils.push_back(-v.cam_from_ref.rotation.transpose() * v.cam_from_ref.translation_mm);
    sum += v.cam_from_ref.rotation.transpose();  // ref_from_cam
  }
  // The chordal mean of the orientations (the rotation nearest the mean matrix).
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(sum, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d r = svd.matrixU() * svd.matrixV().transpose();
  if (r.determinant() < 0) {
    Eigen::Matrix3d u = svd.matrixU();
    u.col(2) *= -1;
    r = u * svd.matrixV().transpose();
  }
  Vec3 mean = Vec3::Zero();
  for (const Vec3& p : pupils) mean += p / static_cast<double>(pupils.size());
  for (const Vec3& a : pupils) {
    for (const Vec3& b : pupils) c.baseline_mm = std::max(c.baseline_mm, (a - b).norm());
  }
  c.ref_from_centre.rotation = r;
  c.ref_from_centre.translation_mm = mean;
  return c;
}
}  // namespace

std::vector<Pose> SetPoses(const Scene& scene, const SetOptions& o) { return SetPosesSeenBy({SetView{scene, Pose{}}}, o); }

std::vector<Pose> SetPosesSeenBy(const std::vector<SetView>& views, const SetOptions& o) {
  if (views.empty()) throw InvalidInput("cameras", "a set needs at least one camera");
  const Scene& scene = views.front().scene;
  for (const SetView& v : views) {
    if (!v.scene.focus_distance_mm) throw InvalidInput("focus_distance_mm", "a set needs one focus for all its images");
  }
  if (o.count < 1 || o.count > 10000) throw InvalidInput("count", "must be 1 to 10000");
  if (!(o.max_tilt_deg >= 0 && o.max_tilt_deg < 80)) throw InvalidInput("max_tilt_deg", "must be 0 to 80 degrees");
  if (!(o.max_roll_deg >= 0 && o.max_roll_deg <= 180)) throw InvalidInput("max_roll_deg", "must be 0 to 180 degrees");
  if (!(o.margin >= 0 && o.margin < 0.4)) throw InvalidInput("margin", "must be 0 to 0.4");
  if (!(o.min_whole_fraction > 0 && o.min_whole_fraction <= 1)) {
    throw InvalidInput("min_whole_fraction", "must be a fraction above 0, up to 1 (the whole target in every image)");
  }
  if (o.min_whole_fraction < 1 && scene.target.kind != calib::TargetKind::kCoded) {
    throw InvalidInput("min_whole_fraction", "partial views are for coded targets (their detector reads targets one by one)");
  }
  // Each view in water and in air (a bare camera: in air only), resolved once; the ranges are the
  // first view's.
  struct Check {
    Scene scene;
    Setup setup;
    Pose cam_from_ref;
  };
  std::vector<Check> checks;
  for (const SetView& v : views) {
    for (const Medium m : {Medium::kWater, Medium::kAir}) {
      if (v.scene.bare && m == Medium::kWater) continue;
      Scene sc = v.scene;
      sc.medium = m;
      const Setup st = Resolve(sc);
      checks.push_back({std::move(sc), st, v.cam_from_ref});
    }
  }
  const Setup& sw = checks.front().setup;
  const camera::Sensor& sensor = sw.camera.sensor;
  std::vector<Vec3> pts;  // the target's points (coded: not the ids that are no target)
  const auto all = calib::TargetPoints(scene.target);
  const std::vector<bool> has = calib::TargetPointMask(scene.target);  // HasPoint per id lays the sheet out each time
  for (std::size_t i = 0; i < all.size(); ++i) {
    if (i < has.size() && has[i]) pts.push_back(all[i]);
  }
  double span = 0;  // the target's size
  for (const Vec3& p : pts) span = std::max(span, (p - pts.front()).norm());
  const bool partial = o.min_whole_fraction < 1;
  const std::size_t needed =
      static_cast<std::size_t>(std::ceil(o.min_whole_fraction * static_cast<double>(pts.size()) - 1e-9));
  const double f_px = sw.camera.FocalLengthPx();
  // Several cameras: the poses are drawn in a frame between them (the mean of their pupils, the
  // mean of their orientations), through the first camera's model, so the target's centre covers
  // their common field; one camera: its own frame.
  const RigCentre centre = CentreOf(views);
  double near = o.near_mm, far = o.far_mm;
  if (near == 0 && far == 0) {  // the target fills 80 % … 30 % of the frame's width (less the baseline)
    near = f_px * (span / 0.8 + centre.baseline_mm) / sensor.width_px;
    far = f_px * (span / 0.3 + centre.baseline_mm) / sensor.width_px;
  }
  if (!(near > 0 && far >= near && std::isfinite(far))) throw InvalidInput("near_mm", "must be near <= far, both > 0");
  auto fits = [&](const Scene& sc, const Setup& st) {
    const camera::Sensor& sensor = st.camera.sensor;
    const double mu = o.margin * std::max(sensor.width_px, sensor.height_px);
    try {
      const std::vector<TruthPoint> truth = GroundTruth(sc, st);
      if (truth.size() < needed) return false;  // coded targets not whole in the frame are left out
      if (partial) return true;  // a partial view: the targets kept image whole, wherever they are
      for (const TruthPoint& tp : truth) {
        for (const Vec2& uv : tp.pixel_per_band) {
          if (uv.x() < mu || uv.y() < mu || uv.x() > sensor.width_px - 1 - mu || uv.y() > sensor.height_px - 1 - mu) {
            return false;
          }
        }
      }
      return true;
    } catch (const InvalidInput&) {
      return false;
    }
  };
  Rng rng{o.seed * 0x9E3779B97F4A7C15ull + 12345};
  std::vector<Pose> poses;
  // The target's centre is stratified over the frame too, cut into 3 × 3 cells: pose i aims at cell
  // kCells[9i / N] (centre and edges for the near poses, whose large targets cannot reach a corner
  // anyway, the corners for the far ones), so that the frame's corners, where a fitted distortion
  // is least constrained, see target points. A cell no pose fits falls back to the whole frame.
  constexpr int kCells[9][2] = {{1, 1}, {1, 0}, {0, 1}, {2, 1}, {1, 2}, {0, 0}, {2, 0}, {0, 2}, {2, 2}};
  for (int i = 0; i < o.count; ++i) {
    bool found = false;
    const int* cell = kCells[i * 9 / o.count];
    for (int attempt = 0; attempt < 4000 && !found; ++attempt) {
      // Distances stratified over the range (image i in the i-th slice), the rest uniform.
      const double dist = near + (far - near) * ((i % o.count) + rng.Uniform()) / o.count;
      const bool in_cell = attempt < 1000;
      const double cu = in_cell ? (cell[0] + rng.Uniform()) / 3 : rng.Uniform();
      const double cv = in_cell ? (cell[1] + rng.Uniform()) / 3 : rng.Uniform();
      const Vec2 centre_px(cu * (sensor.width_px - 1), cv * (sensor.height_px - 1));
      const double tx = (2 * rng.Uniform() - 1) * o.max_tilt_deg, ty = (2 * rng.Uniform() - 1) * o.max_tilt_deg;
      const double roll = (2 * rng.Uniform() - 1) * o.max_roll_deg;
      auto pose_at = [&](const Vec2& px) -> std::optional<Pose> {
        const auto dir = sw.camera.Unproject(px);
        if (!dir || !(dir->z() > 0.2)) return std::nullopt;
        const Vec3 c = *dir * (dist / dir->z());
        Pose pose = Compose(centre.ref_from_centre, PoseFacing(scene.target, c.z(), c.head<2>(), tx, ty, roll));
        for (Check& ch : checks) {
          ch.scene.pose = Compose(ch.cam_from_ref, pose);
          if (!fits(ch.scene, ch.setup)) return std::nullopt;
        }
        return pose;
      };
      std::optional<Pose> pose = pose_at(centre_px);
      if (!pose) continue;
      if (in_cell) {
        // Pushed out toward the cell's side of the frame (for a corner cell: diagonally, then along
        // u, then along v) as far as the target still fits, by bisection on the shift: the target
        // reaches the frame's edge or corner.
        const Vec2 out = Vec2(cell[0] - 1, cell[1] - 1).cwiseProduct(Vec2(sensor.width_px, sensor.height_px)) / 2;
        Vec2 at = centre_px;
        for (const Vec2& step : {out, Vec2(out.x(), 0), Vec2(0, out.y())}) {
          if (step.isZero()) continue;
          double lo = 0, hi = 1;
          for (int k = 0; k < 6; ++k) {
            const double mid = 0.5 * (lo + hi);
            if (auto p = pose_at(at + mid * step)) {
              pose = p;
              lo = mid;
            } else {
              hi = mid;
            }
          }
          at += lo * step;
        }
      }
      poses.push_back(*pose);
      found = true;
    }
    if (!found) {
      throw InvalidInput("count", fmt::format("no pose puts the whole target inside the frame at {:.0f}-{:.0f} mm "
                                                "(pose {} of {}): a smaller target or other distances", near, far, i + 1,
                                                o.count));
    }
  }
  return poses;
}

}  // namespace porthole::render
