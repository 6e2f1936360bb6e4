// What the rig formats of rig_files.h hold alike (rig_internal.h): cameras from a camera matrix and
// distortion vector, a camera as the opencv or Kannala–Brandt model a format holds (refit over the
// image where it is not one, interop.h's ConvertCalibration and interop/refit.h), the relative pose
// of a pair, and the unit of a translation the file does not state (docs/interop.md, "Rig files").
#include <fmt/format.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "porthole/camera/validate.h"
#include "porthole/core/error.h"
#include "porthole/interop/interop.h"
#include "porthole/interop/refit.h"
#include "porthole/interop/rig_internal.h"
#include "porthole/interop/text.h"

namespace porthole::interop::detail {
namespace {

using camera::Camera;
using camera::CameraModelId;
using OpenCV = camera::OpenCVModel;

// 17 significant digits, always with a decimal point (PyYAML reads "500" as an int and "1e-05" as a
// string; Kalibr's reader insists on floats).
std::string Float(double v) {
  std::string s = fmt::format("{:.17g}", v);
  if (s.find_first_of(".n") != std::string::npos) return s;  // has a point (or nan/inf: refused earlier)
  const auto e = s.find('e');
  if (e == std::string::npos) return s + ".0";
  return s.substr(0, e) + ".0" + s.substr(e);
}

double UnitMm(LengthUnit u) { return u == LengthUnit::kMm ? 1.0 : u == LengthUnit::kCm ? 10.0 : 1000.0; }
std::string_view UnitName(LengthUnit u) {
  return u == LengthUnit::kMm ? "mm" : u == LengthUnit::kCm ? "cm" : u == LengthUnit::kM ? "m" : "unstated";
}

// `src` refit over the image into `start`'s model (opencv or kannala-brandt) with the parameters
// `free` adjusted.
template <typename M>
Fitted Refit(const Camera& src, Camera start, const std::vector<bool>& free, const std::string& field) {
  Fitted out{std::move(start), false, {}};
  camera::VisitModel(src.model, [&](auto model) {
    using S = decltype(model);
    const refit::ListProjector<S> sp{src.sensor};
    const auto rays = refit::GridRays(src.sensor, [&](const Eigen::Vector2d& uv) { return src.Unproject(uv); });
    const refit::ProjectedRays data = refit::ProjectRays(sp, src.params, rays);
    const refit::ListProjector<M> dst{src.sensor};
    out.fit = refit::Fit(dst, &out.cam.params, free, data.rays, data.px);
  });
  const std::string what = fmt::format("the refit of the {} camera to the {} model", src.model_name(), out.cam.model_name());
  camera::RequirePossibleResult(out.cam, out.fit.rms_px, field, what);
  if (!(out.fit.rms_px <= kMaxRefitRmsPx)) {
    throw InvalidInput(field, fmt::format("{} misses the camera by RMS {:.3g} px (max {:.3g} px) over the image, above the {:g} px "
                                          "a conversion may differ: the format cannot hold this camera",
                                          what, out.fit.rms_px, out.fit.max_px, kMaxRefitRmsPx));
  }
  return out;
}

}  // namespace

Eigen::Matrix3d Rotation(const std::vector<double>& v, const std::string& where) {
  Eigen::Matrix3d r;
  for (int a = 0; a < 3; ++a) {
    for (int b = 0; b < 3; ++b) r(a, b) = v[3 * a + b];
  }
  if (!((r.transpose() * r - Eigen::Matrix3d::Identity()).norm() < 1e-6 && r.determinant() > 0)) {
    throw InvalidInput(where, "is not a rotation matrix (orthonormal, determinant +1)");
  }
  return r;
}

Eigen::Vector3d RotationVector(const Eigen::Matrix3d& r) {
  const Eigen::AngleAxisd aa(r);
  return aa.angle() * aa.axis();
}
Eigen::Matrix3d FromRotationVector(const Eigen::Vector3d& v) {
  return v.norm() > 0 ? Eigen::AngleAxisd(v.norm(), v.normalized()).toRotationMatrix() : Eigen::Matrix3d::Identity();
}

Camera PixelOpenCV(int w, int h, double pitch, const std::vector<double>& k, const std::vector<double>& d) {
  Camera c{CameraModelId::kOpenCV, {w, h, pitch}, std::vector<double>(OpenCV::kNumParams, 0.0)};
  c.params[OpenCV::kFx] = k[0];
  c.params[OpenCV::kFy] = k[4];
  c.params[OpenCV::kCx] = k[2];
  c.params[OpenCV::kCy] = k[5];
  for (std::size_t i = 0; i < d.size() && i < 8; ++i) c.params[OpenCV::kK1 + i] = d[i];
  return c;
}
Camera PixelKB(int w, int h, double pitch, const std::vector<double>& k, const std::vector<double>& d) {
  return Camera{CameraModelId::kKannalaBrandt, {w, h, pitch}, {k[0], k[4], k[2], k[5], d[0], d[1], d[2], d[3]}};
}

std::vector<double> CheckCameraMatrix(const std::vector<double>& k, const std::string& where) {
  if (k[1] != 0 || k[3] != 0 || k[6] != 0 || k[7] != 0 || k[8] != 1 || !(k[0] > 0 && k[4] > 0)) {
    throw InvalidInput(where, "must be [fx 0 cx; 0 fy cy; 0 0 1] with fx, fy > 0 (no skew)");
  }
  return k;
}

// OpenCV's distortion vector: 4, 5, 8, or 12/14 with zero thin-prism and tilt terms.
std::vector<double> CheckOpenCVDistortion(const std::vector<double>& d, const std::string& where) {
  const std::size_t n = d.size();
  if (n != 4 && n != 5 && n != 8 && n != 12 && n != 14) {
    throw InvalidInput(where, fmt::format("has {} entries; OpenCV has 4, 5, 8, 12 or 14", n));
  }
  for (std::size_t i = 8; i < n; ++i) {
    if (d[i] != 0) throw InvalidInput(where, "thin-prism s1-s4 and tilt tau_x, tau_y must be 0 (porthole's opencv model has k1-k6, p1, p2)");
  }
  return d;
}

// The camera as an opencv camera whose distortion the first `n_dist` coefficients hold (4: k1 k2 p1
// p2; 5: + k3; 8: + k4 k5 k6): exact when it already is, else refit over the image.
Fitted AsOpenCV(const Camera& c, int n_dist, const std::string& field) {
  Camera start;
  if (c.model == CameraModelId::kOpenCV) {
    start = c;
  } else if (c.model == CameraModelId::kBrown) {
    start = ConvertCalibration(WithoutSigma(c, ""), CameraModelId::kOpenCV, field).camera;  // the closed form
  } else if (c.model == CameraModelId::kKannalaBrandt) {
    start = Camera{CameraModelId::kOpenCV, c.sensor, std::vector<double>(OpenCV::kNumParams, 0.0)};
    std::copy(c.params.begin(), c.params.begin() + 4, start.params.begin());
  } else if (c.model == CameraModelId::kEquidistant) {
    const Camera kb = ConvertCalibration(WithoutSigma(c, ""), CameraModelId::kKannalaBrandt, field).camera;
    return AsOpenCV(kb, n_dist, field);
  } else {
    ConvertCalibration(WithoutSigma(c, ""), CameraModelId::kOpenCV, field);  // throws its line
  }
  for (int i = OpenCV::kK1 + n_dist; i < OpenCV::kNumParams; ++i) start.params[i] = 0;
  if (c.model == CameraModelId::kOpenCV && start.params == c.params) return {c, true, {}};
  std::vector<bool> free(OpenCV::kNumParams, false);
  for (int i = 0; i < OpenCV::kK1 + n_dist; ++i) free[i] = true;
  return Refit<OpenCV>(c, start, free, field);
}

// Kannala–Brandt (cv::fisheye, Kalibr's equi, ROS's equidistant): exact from kannala-brandt and
// equidistant; nullopt for other models.
std::optional<Camera> AsKB(const Camera& c, const std::string& field) {
  if (c.model == CameraModelId::kKannalaBrandt) return c;
  if (c.model == CameraModelId::kEquidistant) {
    return ConvertCalibration(WithoutSigma(c, ""), CameraModelId::kKannalaBrandt, field).camera;
  }
  return std::nullopt;
}

// The fewest of 4, 5, 8 OpenCV coefficients that hold an opencv camera exactly.
int OpenCVCount(const Camera& c) {
  const auto& p = c.params;
  if (p[OpenCV::kK4] != 0 || p[OpenCV::kK5] != 0 || p[OpenCV::kK6] != 0) return 8;
  return p[OpenCV::kK3] != 0 ? 5 : 4;
}

std::vector<double> KMatrix(const Camera& c) {
  const auto& p = c.params;
  return {p[0], 0, p[2], 0, p[1], p[3], 0, 0, 1};
}

std::string NumList(const std::vector<double>& v, std::string_view sep) {
  std::string s;
  for (double x : v) {
    if (!s.empty()) s.append(sep);
    s.append(Float(x));
  }
  return s;
}

void RequireNoPort(const RigFile& rig, RigFormat format, const std::string& field) {
  for (const auto& c : rig.cameras) {
    if (!c.port.empty()) {
      throw InvalidInput(field, fmt::format("camera {} is behind a port ({}): {} has no refraction (keep porthole's rig "
                                            "JSON, or calibrate in air for this format)",
                                            c.name, c.port, RigFormatName(format)));
    }
  }
}

void RequirePair(const RigFile& rig, RigFormat format, const std::string& field) {
  if (rig.cameras.size() != 2) {
    throw InvalidInput(field, fmt::format("{} holds a stereo pair; the rig has {} cameras (kalibr and json hold any number)",
                                          RigFormatName(format), rig.cameras.size()));
  }
}

// R, T of the pair: x2 = R·x1 + T (mm), from the cameras' cam_from_rig.
std::pair<Eigen::Matrix3d, Eigen::Vector3d> Relative(const RigFileCamera& a, const RigFileCamera& b) {
  const Eigen::Matrix3d r = b.rotation * a.rotation.transpose();
  return {r, b.translation_mm - r * a.translation_mm};
}

RigFileCamera Camera1(const std::string& name, const Camera& cam) {
  RigFileCamera c;
  c.name = name;
  c.calibration = WithoutSigma(cam, "");
  c.calibration.label = name;
  return c;
}

PairCameras OpenCVPair(const RigFile& rig, RigFormat format, const std::string& field) {
  RequirePair(rig, format, field);
  RequireNoPort(rig, format, field);
  const auto one = [&](const RigFileCamera& c) {
    const std::string f = field + ": camera " + c.name;
    if (c.calibration.camera.model == CameraModelId::kOpenCV) {
      return AsOpenCV(c.calibration.camera, OpenCVCount(c.calibration.camera), f);
    }
    return AsOpenCV(c.calibration.camera, c.calibration.camera.model == CameraModelId::kBrown ? 5 : 8, f);
  };
  PairCameras p{one(rig.cameras[0]), one(rig.cameras[1])};
  const auto& s0 = p.first.cam.sensor;
  const auto& s1 = p.second.cam.sensor;
  if (format != RigFormat::kViameNpz && (s0.width_px != s1.width_px || s0.height_px != s1.height_px)) {
    throw InvalidInput(field, fmt::format("OpenCV's stereo file has one image size; the cameras' are {}x{} and {}x{}",
                                          s0.width_px, s0.height_px, s1.width_px, s1.height_px));
  }
  return p;
}

std::vector<double> Coefficients(const Camera& c, int n) {
  return std::vector<double>(c.params.begin() + OpenCV::kK1, c.params.begin() + OpenCV::kK1 + n);
}

// The unit of an unstated T: the file's T_unit, else the option, else refused.
double TUnitMm(const YNode* stated, const RigReadOptions& o, const std::string& where, RigFile* rig) {
  if (stated != nullptr) {
    const std::string u = Trim(stated->scalar);
    const LengthUnit unit = LengthUnitFromName(u, where + ": T_unit");
    if (o.length_unit != LengthUnit::kUnstated && o.length_unit != unit) {
      throw InvalidInput(where + ": T_unit", fmt::format("the file states {}, but {} was given", u, UnitName(o.length_unit)));
    }
    rig->length_unit_note = u + ", stated in the file";
    return UnitMm(unit);
  }
  if (o.length_unit == LengthUnit::kUnstated) {
    throw InvalidInput(where + ": T", "the file does not state T's unit (the calibration target's): give the length unit "
                                      "(choices: mm, cm, m)");
  }
  rig->length_unit_note = std::string(UnitName(o.length_unit)) + ", given";
  return UnitMm(o.length_unit);
}

RigFile PairRig(const Camera& c1, const Camera& c2, const Eigen::Matrix3d& r, const Eigen::Vector3d& t_mm,
                const std::string& n1, const std::string& n2) {
  RigFile rig;
  rig.cameras.push_back(Camera1(n1, c1));
  rig.cameras.push_back(Camera1(n2, c2));
  rig.cameras[1].rotation = r;
  rig.cameras[1].translation_mm = t_mm;
  return rig;
}

}  // namespace porthole::interop::detail
