// Proves every model of the closed camera-model list (camera/models.h) with one typed driver:
// parameter metadata complete and consistent with the run-time list; Unproject then Project returns
// to the pixel within 1e-9 px over the whole image and Project then Unproject to the ray over the
// whole field; Jets through Project and Unproject equal 5-point central differences to 1e-6
// relative; the ideal camera is the textbook projection. Adding a model: one line in kExamples.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <set>
#include <string>

#include "porthole/camera/camera.h"

namespace porthole::camera {
namespace {

// Nikon D300: 4288 × 2848 px, 5.5 µm pitch.
const Sensor kD300{4288, 2848, 0.0055};

// One realistic camera per model, whose valid field covers the whole D300 frame.
template <typename M>
std::vector<double> Example();
// clang-format off
template <> std::vector<double> Example<BrownModel>() { return {25.801, -0.026, -0.144, 1.842e-4, -3.030e-7, 2e-10, 6.582e-6, 1.620e-5, 1e-4, -5e-5}; }
template <> std::vector<double> Example<OpenCVModel>() { return {4690, 4692, 2150, 1420, -0.1, 0.05, 1e-4, -2e-4, -0.01, 0.02, 0.005, 0.001}; }
template <> std::vector<double> Example<KannalaBrandtModel>() { return {1909, 1910, 2144, 1424, 0.02, -0.005, 0.001, -0.0002}; }
template <> std::vector<double> Example<EquidistantModel>() { return {1700, 2140, 1426, 0.01, -0.001}; }
template <> std::vector<double> Example<EquisolidModel>() { return {1909, 2146, 1422, 0.005, 0.0}; }
template <> std::vector<double> Example<StereographicModel>() { return {1500, 2143, 1423, -0.01, 0.001}; }
template <> std::vector<double> Example<OrthographicModel>() { return {3000, 2143.5, 1423.5, 0.003, 0.0}; }
// clang-format on

template <typename Tuple>
struct ToTypes;
template <typename... M>
struct ToTypes<std::tuple<M...>> {
  using type = ::testing::Types<M...>;
};

template <typename M>
class CameraModelTest : public ::testing::Test {};
TYPED_TEST_SUITE(CameraModelTest, ToTypes<CameraModelList>::type);


TYPED_TEST(CameraModelTest, MetadataIsCompleteAndMatchesTheList) {
  using M = TypeParam;
  ASSERT_EQ(static_cast<int>(M::kParams.size()), M::kNumParams);
  ASSERT_LE(M::kNumParams, kMaxModelParams);
  std::set<std::string_view> names, keys;
  for (const ParamInfo& p : M::kParams) {
    EXPECT_FALSE(p.name.empty());
    EXPECT_FALSE(p.json_key.empty());
    EXPECT_FALSE(p.unit.empty());
    names.insert(p.name);
    keys.insert(p.json_key);
    // A dimensional parameter's key carries its unit (docs/conventions.md).
    if (p.unit == "mm" || p.unit == "px") {
      const std::string suffix = "_" + std::string(p.unit);
      EXPECT_TRUE(p.json_key.ends_with(suffix)) << p.json_key;
    }
  }
  EXPECT_EQ(static_cast<int>(names.size()), M::kNumParams) << "parameter names not unique";
  EXPECT_EQ(static_cast<int>(keys.size()), M::kNumParams) << "JSON keys not unique";
  const ModelInfo& info = Info(M::kId);
  EXPECT_EQ(info.name, M::kName);
  EXPECT_EQ(info.num_params, M::kNumParams);
  EXPECT_FALSE(info.description.empty());
  EXPECT_EQ(ModelFromName(M::kName), M::kId);
  EXPECT_EQ(Example<M>().size(), static_cast<size_t>(M::kNumParams));
  for (int i = 0; i < M::kNumParams; ++i) {
    EXPECT_EQ(ParamIndex(M::kId, M::kParams[i].name), i);
    EXPECT_EQ(ParamIndex(M::kId, M::kParams[i].json_key), i);
  }
  EXPECT_NO_THROW(ValidateCamera(Camera{M::kId, kD300, Example<M>()}));
  // The shared layout: focal lengths (px or mm) first, then the principal point, then distortion.
  ASSERT_GE(M::kNumFocal, 1);
  ASSERT_EQ(M::kFirstDistortion, M::kNumFocal + 2);
  for (int i = 0; i < M::kFirstDistortion; ++i) {
    EXPECT_TRUE(M::kParams[i].unit == "px" || M::kParams[i].unit == "mm") << M::kParams[i].name;
  }
  Camera cam{M::kId, kD300, Example<M>()};
  SetFocalLengthPx(&cam, 1234.5);
  EXPECT_NEAR(cam.FocalLengthPx(), 1234.5, 1e-9);
}

TYPED_TEST(CameraModelTest, UnprojectThenProjectReturnsToThePixelOverTheWholeImage) {
  using M = TypeParam;
  const Camera cam{M::kId, kD300, Example<M>()};
  double worst = 0;
  for (const Eigen::Vector2d& uv : FramePixels(kD300, 41, 31)) {
    const auto ray = cam.Unproject(uv);
    ASSERT_TRUE(ray) << "pixel " << uv.transpose() << " has no ray";
    EXPECT_NEAR(ray->norm(), 1.0, 1e-14);
    // Any point along the ray, near or far, projects to the same pixel.
    for (double range_mm : {300.0, 20000.0}) {
      const auto back = cam.Project(range_mm * *ray);
      ASSERT_TRUE(back) << "pixel " << uv.transpose();
      worst = std::max(worst, (*back - uv).norm());
    }
  }
  EXPECT_LE(worst, 1e-9) << M::kName;
}

TYPED_TEST(CameraModelTest, ProjectThenUnprojectReturnsToTheRayOverTheWholeField) {
  using M = TypeParam;
  const Camera cam{M::kId, kD300, Example<M>()};
  // The field the frame covers: the largest angle of a corner's ray.
  double max_angle = 0;
  for (const Eigen::Vector2d& uv : FramePixels(kD300, 2, 2)) {
    max_angle = std::max(max_angle, std::acos((*cam.Unproject(uv))(2)));
  }
  double worst_px = 0;
  for (int a = 0; a <= 20; ++a) {
    const double theta = max_angle * a / 20.0;
    for (int k = 0; k < 16; ++k) {
      const double phi = 2 * std::numbers::pi * k / 16.0;
      const Eigen::Vector3d ray(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi),
                                std::cos(theta));
      const auto uv = cam.Project(1000.0 * ray);
      ASSERT_TRUE(uv) << "theta " << theta;
      const auto back = cam.Unproject(*uv);
      ASSERT_TRUE(back);
      EXPECT_LE((*back - ray).norm(), 1e-11) << "theta " << theta;
      worst_px = std::max(worst_px, (*cam.Project(2000.0 * *back) - *uv).norm());
    }
  }
  EXPECT_LE(worst_px, 1e-9) << M::kName;
}

// 5-point central difference of f at x along coordinate i with step h.
template <typename F>
Eigen::VectorXd CentralDifference(F f, std::vector<double> x, int i, double h) {
  auto at = [&](double dx) {
    std::vector<double> y = x;
    y[i] += dx;
    return f(y);
  };
  return (-at(2 * h) + 8 * at(h) - 8 * at(-h) + at(-2 * h)) / (12 * h);
}

// The difference step for a value x of typical magnitude `typical` (0: x itself; a zero
// dimensionless coefficient gets 1e-7).
double Step(double x, double typical) {
  const double m = std::max(std::abs(x), typical);
  return m > 0 ? 1e-5 * m : 1e-7;
}

// Largest relative difference of the columns of two Jacobians. A column passes when it agrees to
// 1e-6 relative, or when the change it predicts over its difference step h_j differs by less than
// `floor` (output units): near the axis some derivatives are so small that their effect over any
// usable step is below the rounding of the output, and no difference quotient can resolve them.
double WorstColumnError(const Eigen::MatrixXd& jet, const Eigen::MatrixXd& fd,
                        const std::vector<double>& steps, double floor) {
  double worst = 0;
  for (int j = 0; j < jet.cols(); ++j) {
    const double err = (jet.col(j) - fd.col(j)).norm();
    if (err * steps[j] <= floor) continue;
    worst = std::max(worst, err / jet.col(j).norm());
  }
  return worst;
}

TYPED_TEST(CameraModelTest, ProjectJetsEqualCentralDifferences) {
  using M = TypeParam;
  constexpr int N = M::kNumParams + 3;
  constexpr double kFloor = 1e-9;  // px
  using J = ceres::Jet<double, N>;
  const std::vector<double> params = Example<M>();
  const Camera cam{M::kId, kD300, params};
  // Points toward the centre, an edge and a corner of the frame.
  for (const Eigen::Vector2d& uv : FramePixels(kD300, 3, 3)) {
    const Eigen::Vector3d point = 1500.0 * *cam.Unproject(uv);
    std::vector<double> x = params;
    x.insert(x.end(), point.data(), point.data() + 3);
    std::array<J, N> xj;
    for (int i = 0; i < N; ++i) xj[i] = J(x[i], i);
    const auto uvj = M::template Project<J>(kD300, xj.data(),
                                            Vec3<J>(xj[N - 3], xj[N - 2], xj[N - 1]));
    ASSERT_TRUE(uvj);
    Eigen::MatrixXd jet(2, N), fd(2, N);
    std::vector<double> steps(N);
    auto f = [&](const std::vector<double>& y) {
      const auto r = M::template Project<double>(kD300, y.data(),
                                                 Eigen::Vector3d(y[N - 3], y[N - 2], y[N - 1]));
      return Eigen::VectorXd(*r);
    };
    for (int i = 0; i < N; ++i) {
      jet(0, i) = (*uvj)(0).v(i);
      jet(1, i) = (*uvj)(1).v(i);
      // Steps relative to each value; the point's coordinates relative to its range.
      const double typical = i >= M::kNumParams ? point.norm() : 0.0;
      steps[i] = Step(x[i], typical);
      fd.col(i) = CentralDifference(f, x, i, steps[i]);
    }
    EXPECT_LE(WorstColumnError(jet, fd, steps, kFloor), 1e-6)
        << M::kName << " at " << uv.transpose() << "\njet\n" << jet << "\nfd\n" << fd;
  }
}

TYPED_TEST(CameraModelTest, UnprojectJetsEqualCentralDifferences) {
  using M = TypeParam;
  constexpr int N = M::kNumParams + 2;
  constexpr double kFloor = 1e-12;  // unit-ray components (rad)
  using J = ceres::Jet<double, N>;
  const std::vector<double> params = Example<M>();
  for (const Eigen::Vector2d& uv : FramePixels(kD300, 3, 3)) {
    std::vector<double> x = params;
    x.push_back(uv(0));
    x.push_back(uv(1));
    std::array<J, N> xj;
    for (int i = 0; i < N; ++i) xj[i] = J(x[i], i);
    const auto rj = M::template Unproject<J>(kD300, xj.data(), Vec2<J>(xj[N - 2], xj[N - 1]));
    ASSERT_TRUE(rj);
    Eigen::MatrixXd jet(3, N), fd(3, N);
    std::vector<double> steps(N);
    auto f = [&](const std::vector<double>& y) {
      const auto r = M::template Unproject<double>(kD300, y.data(), Eigen::Vector2d(y[N - 2], y[N - 1]));
      return Eigen::VectorXd(*r);
    };
    for (int i = 0; i < N; ++i) {
      for (int k = 0; k < 3; ++k) jet(k, i) = (*rj)(k).v(i);
      const double typical = i >= M::kNumParams ? 1000.0 : 0.0;  // pixel coordinates
      steps[i] = Step(x[i], typical);
      fd.col(i) = CentralDifference(f, x, i, steps[i]);
    }
    EXPECT_LE(WorstColumnError(jet, fd, steps, kFloor), 1e-6)
        << M::kName << " at " << uv.transpose() << "\njet\n" << jet << "\nfd\n" << fd;
  }
}

TYPED_TEST(CameraModelTest, IdealCameraIsTheUndistortedProjection) {
  using M = TypeParam;
  const double f_px = 2000;
  const Camera cam = Camera::Ideal(M::kId, kD300, f_px);
  EXPECT_NO_THROW(ValidateCamera(cam));
  EXPECT_NEAR(cam.FocalLengthPx(), f_px, 1e-9);
  const Eigen::Vector2d centre(0.5 * (kD300.width_px - 1), 0.5 * (kD300.height_px - 1));
  EXPECT_NEAR((cam.PrincipalPointPx() - centre).norm(), 0, 1e-9);
  EXPECT_NEAR((*cam.Project(Eigen::Vector3d(0, 0, 1000)) - centre).norm(), 0, 1e-9);
  // At 30° off axis the radius is f·g(30°) of the model's projection (rectilinear: tan).
  const double theta = std::numbers::pi / 6;
  const Projection proj = [] {
    if constexpr (std::is_base_of_v<IdealFisheyeModel<Projection::kEquidistant>, M> ||
                  std::is_same_v<M, KannalaBrandtModel>) {
      return Projection::kEquidistant;
    } else if constexpr (std::is_base_of_v<IdealFisheyeModel<Projection::kEquisolid>, M>) {
      return Projection::kEquisolid;
    } else if constexpr (std::is_base_of_v<IdealFisheyeModel<Projection::kStereographic>, M>) {
      return Projection::kStereographic;
    } else if constexpr (std::is_base_of_v<IdealFisheyeModel<Projection::kOrthographic>, M>) {
      return Projection::kOrthographic;
    } else {
      return Projection::kRectilinear;
    }
  }();
  const auto uv = cam.Project(Eigen::Vector3d(std::sin(theta), 0, std::cos(theta)));
  ASSERT_TRUE(uv);
  EXPECT_NEAR((*uv)(0) - centre(0), f_px * ProjectionRadius(proj, theta), 1e-9);
  EXPECT_NEAR((*uv)(1) - centre(1), 0, 1e-9);
  EXPECT_EQ(M::kCaps.fisheye, IsFisheye(proj));
}

TYPED_TEST(CameraModelTest, FisheyesSeeBeyondNinetyDegreesAndRectilinearsDoNot) {
  using M = TypeParam;
  const Camera cam{M::kId, kD300, Example<M>()};
  const double theta = 95.0 * std::numbers::pi / 180;
  const auto uv = cam.Project(Eigen::Vector3d(std::sin(theta), 0, std::cos(theta)));
  const bool orthographic = M::kId == CameraModelId::kOrthographic;
  EXPECT_EQ(uv.has_value(), M::kCaps.fisheye && !orthographic) << M::kName;
}

// ---------------------------------------------------------------------------------------------
// The projections themselves (camera/projection.h) against their closed forms and inverses.

TEST(Projection, RadiusAndAngleAreInversesWithTheTextbookValues) {
  const double t = 1.0;  // rad
  EXPECT_DOUBLE_EQ(ProjectionRadius(Projection::kRectilinear, t), std::tan(t));
  EXPECT_DOUBLE_EQ(ProjectionRadius(Projection::kEquidistant, t), t);
  EXPECT_DOUBLE_EQ(ProjectionRadius(Projection::kEquisolid, t), 2 * std::sin(t / 2));
  EXPECT_DOUBLE_EQ(ProjectionRadius(Projection::kStereographic, t), 2 * std::tan(t / 2));
  EXPECT_DOUBLE_EQ(ProjectionRadius(Projection::kOrthographic, t), std::sin(t));
  for (Projection p : kAllProjections) {
    for (double th = 0.01; th < MaxFieldAngleRad(p); th += 0.05) {
      const auto back = ProjectionAngle(p, ProjectionRadius(p, th));
      ASSERT_TRUE(back);
      EXPECT_NEAR(*back, th, 1e-12) << ProjectionName(p);
      const double h = 1e-6;
      const double fd = (ProjectionRadius(p, th + h) - ProjectionRadius(p, th - h)) / (2 * h);
      EXPECT_NEAR(ProjectionRadiusDerivative(p, th), fd, 1e-6 * std::abs(fd)) << ProjectionName(p);
    }
    EXPECT_EQ(ProjectionFromName(ProjectionName(p)), p);
  }
  EXPECT_FALSE(ProjectionAngle(Projection::kOrthographic, 1.01));
  EXPECT_FALSE(ProjectionAngle(Projection::kEquisolid, 2.01));
  EXPECT_FALSE(ProjectionFromName("fisheye"));
}

TEST(CameraModels, NamesAndAliasesResolveAndUnknownNamesListTheKnownOnes) {
  EXPECT_EQ(ModelFromName("OPENCV_FISHEYE"), CameraModelId::kKannalaBrandt);
  EXPECT_EQ(ModelFromName("FULL_OPENCV"), CameraModelId::kOpenCV);
  EXPECT_EQ(ModelFromName("Brown"), CameraModelId::kBrown);
  try {
    ModelFromName("pinhole-ish", "--model");
    FAIL() << "no throw";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.field(), "--model");
    EXPECT_NE(std::string(e.what()).find("kannala-brandt"), std::string::npos) << e.what();
  }
  // The list holds every id once, in order.
  int i = 0;
  for (const ModelInfo& m : CameraModels()) EXPECT_EQ(int(m.id), i++);
}

TEST(CameraModels, InvalidCamerasNameTheField) {
  Camera c = Camera::Ideal(CameraModelId::kKannalaBrandt, kD300, 1900);
  c.params.pop_back();
  EXPECT_THROW(ValidateCamera(c), InvalidInput);
  c = Camera::Ideal(CameraModelId::kKannalaBrandt, kD300, 1900);
  c.params[4] = std::nan("");
  try {
    ValidateCamera(c, "air");
    FAIL() << "no throw";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.field(), "air.k1");
  }
  EXPECT_THROW(ToBrown(c), InvalidInput);
  const BrownParams b{25.8, 0.1, -0.1, 1e-4, 0, 0, 0, 0, 0, 0};
  EXPECT_EQ(ToBrown(FromBrown(b, kD300)).c_mm, 25.8);
}

}  // namespace
}  // namespace porthole::camera
