#include "porthole/camera/camera.h"

#include <algorithm>
#include <cctype>

#include <ceres/ceres.h>

namespace porthole::camera {
namespace {

std::string Lower(std::string_view s) {
  std::string out(s);
  for (char& ch : out) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
  std::replace(out.begin(), out.end(), '_', '-');
  return out;
}

// Names other tools give the models of the list (compared after Lower()).
struct Alias {
  std::string_view name;
  CameraModelId id;
};
constexpr Alias kAliases[] = {
    {"opencv", CameraModelId::kOpenCV},           // COLMAP OPENCV
    {"full-opencv", CameraModelId::kOpenCV},      // COLMAP FULL_OPENCV
    {"opencv-fisheye", CameraModelId::kKannalaBrandt},  // COLMAP OPENCV_FISHEYE
    {"fisheye", CameraModelId::kKannalaBrandt},   // cv::fisheye
    {"kb", CameraModelId::kKannalaBrandt},
    {"equisolid-angle", CameraModelId::kEquisolid},
    {"fisheye-equidistant", CameraModelId::kEquidistant},
};

}  // namespace

const std::vector<ModelInfo>& CameraModels() {
  static const std::vector<ModelInfo> list = [] {
    std::vector<ModelInfo> v;
    ForEachModel([&](auto m) {
      using M = decltype(m);
      v.push_back({M::kId, M::kName, M::kDescription, M::kNumParams, M::kNumFocal, M::kFirstDistortion,
                   std::span<const ParamInfo>(M::kParams.data(), M::kParams.size()), M::kCaps});
    });
    return v;
  }();
  return list;
}

const ModelInfo& Info(CameraModelId id) {
  for (const ModelInfo& m : CameraModels()) {
    if (m.id == id) return m;
  }
  throw InternalError("camera model id " + std::to_string(int(id)) + " not in the list");
}

CameraModelId ModelFromName(std::string_view name, const std::string& field) {
  const std::string key = Lower(name);
  for (const ModelInfo& m : CameraModels()) {
    if (key == m.name) return m.id;
  }
  for (const Alias& a : kAliases) {
    if (key == a.name) return a.id;
  }
  std::string known;
  for (const ModelInfo& m : CameraModels()) known += (known.empty() ? "" : ", ") + std::string(m.name);
  throw InvalidInput(field, "unknown camera model '" + std::string(name) + "' (known: " + known + ")");
}

std::optional<int> ParamIndex(CameraModelId id, std::string_view name) {
  const ModelInfo& m = Info(id);
  for (int i = 0; i < m.num_params; ++i) {
    if (m.params[i].name == name || m.params[i].json_key == name) return i;
  }
  return std::nullopt;
}

std::optional<Eigen::Vector2d> Camera::Project(const Eigen::Vector3d& point_in_cam) const {
  return VisitModel(model, [&](auto m) -> std::optional<Eigen::Vector2d> {
    using M = decltype(m);
    PORTHOLE_CHECK(static_cast<int>(params.size()) == M::kNumParams);
    return M::template Project<double>(sensor, params.data(), point_in_cam);
  });
}

std::optional<Eigen::Vector3d> Camera::Unproject(const Eigen::Vector2d& uv) const {
  return VisitModel(model, [&](auto m) -> std::optional<Eigen::Vector3d> {
    using M = decltype(m);
    PORTHOLE_CHECK(static_cast<int>(params.size()) == M::kNumParams);
    return M::template Unproject<double>(sensor, params.data(), uv);
  });
}

double Camera::FocalLengthPx() const {
  return VisitModel(model, [&](auto m) { return decltype(m)::FocalLengthPx(params.data(), sensor); });
}

Eigen::Vector2d Camera::PrincipalPointPx() const {
  return VisitModel(model,
                    [&](auto m) { return decltype(m)::PrincipalPointPx(params.data(), sensor); });
}

Camera Camera::Ideal(CameraModelId model, const Sensor& sensor, double f_px) {
  return {model, sensor, VisitModel(model, [&](auto m) { return decltype(m)::Ideal(f_px, sensor); })};
}

void SetFocalLengthPx(Camera* camera, double f_px) {
  const ModelInfo& m = camera->info();
  for (int i = 0; i < m.num_focal; ++i) {
    camera->params[i] = m.params[i].unit == "mm" ? f_px * camera->sensor.pixel_pitch_mm : f_px;
  }
}

void ValidateCamera(const Camera& camera, const std::string& where) {
  ValidateSensor(camera.sensor);
  const ModelInfo& m = camera.info();
  if (static_cast<int>(camera.params.size()) != m.num_params) {
    throw InvalidInput(where, "model " + std::string(m.name) + " has " +
                                  std::to_string(m.num_params) + " parameters, got " +
                                  std::to_string(camera.params.size()));
  }
  for (int i = 0; i < m.num_params; ++i) {
    RequireFinite(where + "." + std::string(m.params[i].json_key), camera.params[i]);
  }
  if (!(camera.FocalLengthPx() > 0)) {
    throw InvalidInput(where + "." + std::string(m.params[0].json_key), "focal length must be > 0");
  }
}

namespace {

// Residual (px) of one ray: the model's projection minus the ideal projection's pixel.
template <typename M>
struct ProjectionFitResidual {
  Sensor sensor;
  Eigen::Vector3d ray;
  Eigen::Vector2d target_px;
  template <typename T>
  bool operator()(const T* p, T* r) const {
    const auto uv = M::template Project<T>(sensor, p, ray.cast<T>());
    if (!uv) return false;
    r[0] = (*uv)(0) - T(target_px.x());
    r[1] = (*uv)(1) - T(target_px.y());
    return true;
  }
};

}  // namespace

Camera FitToProjection(CameraModelId model, const Sensor& sensor, Projection projection,
                       double f_px, double max_field_rad, double* fit_rms_px) {
  RequirePositive("f_px", f_px);
  RequirePositive("max_field_rad", max_field_rad);
  const double theta_max = std::min(max_field_rad, MaxFieldAngleRad(projection) * 0.999);
  Camera cam = Camera::Ideal(model, sensor, f_px);
  const Eigen::Vector2d centre = cam.PrincipalPointPx();
  // Rays on two azimuths (the fit is radial; two keep fx and fy apart) out to theta_max.
  std::vector<std::pair<Eigen::Vector3d, Eigen::Vector2d>> rays;
  const int n = 40;
  for (int k = 1; k <= n; ++k) {
    const double th = theta_max * k / n;
    const double rr = f_px * ProjectionRadius(projection, th);
    rays.push_back({{std::sin(th), 0, std::cos(th)}, centre + Eigen::Vector2d(rr, 0)});
    rays.push_back({{0, std::sin(th), std::cos(th)}, centre + Eigen::Vector2d(0, rr)});
  }
  const double rms = VisitModel(model, [&](auto m) {
    using M = decltype(m);
    std::array<double, M::kNumParams> p;
    std::copy(cam.params.begin(), cam.params.end(), p.begin());
    ceres::Problem problem;
    for (const auto& [ray, px] : rays) {
      problem.AddResidualBlock(
          new ceres::AutoDiffCostFunction<ProjectionFitResidual<M>, 2, M::kNumParams>(
              new ProjectionFitResidual<M>{sensor, ray, px}),
          nullptr, p.data());
    }
    // The principal point stays at the centre; the focal length too where the model can take
    // the projection's shape with its distortion terms alone.
    std::vector<int> fixed;
    for (int i = M::kNumFocal; i < M::kFirstDistortion; ++i) fixed.push_back(i);
    if (M::kFirstDistortion < M::kNumParams) {
      for (int i = 0; i < M::kNumFocal; ++i) fixed.push_back(i);
    }
    if (static_cast<int>(fixed.size()) == M::kNumParams) {
      problem.SetParameterBlockConstant(p.data());
    } else {
      problem.SetManifold(p.data(), new ceres::SubsetManifold(M::kNumParams, fixed));
    }
    ceres::Solver::Options so;
    so.linear_solver_type = ceres::DENSE_QR;
    so.max_num_iterations = 100;
    so.max_num_consecutive_invalid_steps = 50;
    ceres::Solver::Summary summary;
    ceres::Solve(so, &problem, &summary);
    cam.params.assign(p.begin(), p.end());
    return std::sqrt(2 * summary.final_cost / rays.size());
  });
  if (fit_rms_px != nullptr) *fit_rms_px = rms;
  return cam;
}

Camera FromBrown(const BrownParams& brown, const Sensor& sensor) {
  const auto a = brown.ToArray();
  return {CameraModelId::kBrown, sensor, std::vector<double>(a.begin(), a.end())};
}

BrownParams ToBrown(const Camera& camera, const std::string& field) {
  if (camera.model != CameraModelId::kBrown) {
    throw InvalidInput(field, "needs a Brown calibration, got model " +
                                  std::string(camera.model_name()));
  }
  PORTHOLE_CHECK(camera.params.size() == kBrownNumParams);
  return BrownParams::FromArray(camera.params.data());
}

std::string_view ProjectionName(Projection p) {
  switch (p) {
    case Projection::kRectilinear: return "rectilinear";
    case Projection::kEquidistant: return "equidistant";
    case Projection::kEquisolid: return "equisolid";
    case Projection::kStereographic: return "stereographic";
    case Projection::kOrthographic: return "orthographic";
  }
  return "rectilinear";
}

std::optional<Projection> ProjectionFromName(std::string_view name) {
  for (Projection p : kAllProjections) {
    if (ProjectionName(p) == name) return p;
  }
  return std::nullopt;
}

}  // namespace porthole::camera
