#include "porthole/camera/camera.h"

#include <algorithm>
#include <cctype>

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
