// The residual of bundle.h, shared by its translation units (bundle.cc: central cameras;
// bundle_port.cc, bundle_port_point.cc: cameras behind a port), which instantiate it for every model of the camera list.
#pragma once

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <algorithm>
#include <array>

#include "porthole/calib/bundle.h"

namespace porthole::calib::bundle_detail {

// Which blocks a cost has beside the lens and the pose (in this order: lens, focal scale, port,
// shell values, cam_from_rig, pose, point).
enum : unsigned { kPort = 1, kShell = 2, kRig = 4, kPoint = 8, kFocus = 16 };

// (Project(X in the camera frame) − observed) · weight, px. Project is the lens alone, or the exact
// forward projection through the port (`shell`: the medium's); `point` is X unless kPoint.
template <typename M, unsigned kBlocks>
struct BundleResidual {
  double u_px = 0, v_px = 0, weight = 1;
  camera::Sensor sensor;
  std::array<double, M::kNumParams> scale{};
  const refraction::Shell* shell = nullptr;
  bool in_air = false;
  Eigen::Vector3d point = Eigen::Vector3d::Zero();

  template <typename T>
  bool Evaluate(const T* const* b, T* r) const {
    int i = 0;
    const T* scaled = b[i++];
    const T* focal_scale = (kBlocks & kFocus) ? b[i++] : nullptr;
    const T* port = (kBlocks & kPort) ? b[i++] : nullptr;
    const T* shell_values = (kBlocks & kShell) ? b[i++] : nullptr;
    const T* cam_from_rig = (kBlocks & kRig) ? b[i++] : nullptr;
    const T* pose = b[i++];
    T x[3] = {T(point.x()), T(point.y()), T(point.z())};
    if constexpr ((kBlocks & kPoint) != 0) std::copy(b[i], b[i] + 3, x);
    T cam[M::kNumParams];
    for (int k = 0; k < M::kNumParams; ++k) cam[k] = scaled[k] * T(scale[k]);
    if (focal_scale != nullptr) {
      for (int k = 0; k < M::kNumFocal; ++k) cam[k] *= focal_scale[0];
    }
    T p[3];
    ceres::AngleAxisRotatePoint(pose, x, p);
    for (int k = 0; k < 3; ++k) p[k] += pose[3 + k];
    if (cam_from_rig != nullptr) {
      T q[3];
      ceres::AngleAxisRotatePoint(cam_from_rig, p, q);
      for (int k = 0; k < 3; ++k) p[k] = q[k] + cam_from_rig[3 + k];
    }
    std::optional<camera::Vec2<T>> uv;
    if constexpr ((kBlocks & kPort) != 0) {
      T air_values[refraction::kShellNumParams];
      if (in_air && shell_values != nullptr) {  // the water index factor does not apply in air
        std::copy(shell_values, shell_values + refraction::kShellNumParams, air_values);
        air_values[0] = T(1);
        shell_values = air_values;
      }
      uv = refraction::Project<M, T>(sensor, cam, *shell, port, refraction::Vec3T<T>(p[0], p[1], p[2]),
                                     shell_values);
    } else {
      uv = M::template Project<T>(sensor, cam, camera::Vec3<T>(p[0], p[1], p[2]));
    }
    if (!uv) return false;
    r[0] = ((*uv)(0) - T(u_px)) * T(weight);
    r[1] = ((*uv)(1) - T(v_px)) * T(weight);
    return true;
  }
  template <typename T>
  bool operator()(const T* b0, const T* b1, T* r) const {
    const T* b[] = {b0, b1};
    return Evaluate(b, r);
  }
  template <typename T>
  bool operator()(const T* b0, const T* b1, const T* b2, T* r) const {
    const T* b[] = {b0, b1, b2};
    return Evaluate(b, r);
  }
  template <typename T>
  bool operator()(const T* b0, const T* b1, const T* b2, const T* b3, T* r) const {
    const T* b[] = {b0, b1, b2, b3};
    return Evaluate(b, r);
  }
  template <typename T>
  bool operator()(const T* b0, const T* b1, const T* b2, const T* b3, const T* b4, T* r) const {
    const T* b[] = {b0, b1, b2, b3, b4};
    return Evaluate(b, r);
  }
  template <typename T>
  bool operator()(const T* b0, const T* b1, const T* b2, const T* b3, const T* b4, const T* b5, T* r) const {
    const T* b[] = {b0, b1, b2, b3, b4, b5};
    return Evaluate(b, r);
  }
};

// The functor of one observation (its scale, shell and point filled in).
template <typename M, unsigned kBlocks>
BundleResidual<M, kBlocks> ResidualOf(const BundleCamera& c, const BundleObservation& ob) {
  BundleResidual<M, kBlocks> f;
  f.u_px = ob.u_px, f.v_px = ob.v_px, f.weight = ob.weight;
  f.sensor = c.sensor;
  std::copy(c.scale.begin(), c.scale.end(), f.scale.begin());
  f.in_air = ob.medium == Medium::kAir;
  f.shell = f.in_air ? c.air_shell : c.water_shell;
  f.point = ob.point;
  return f;
}

// The layout bits of an observation of camera c.
inline unsigned LayoutOf(const BundleCamera& c, const BundleObservation& ob) {
  return (ob.focal_scale != nullptr ? kFocus : 0u) | (c.port != nullptr ? kPort : 0u) | (c.shell_values != nullptr ? kShell : 0u) |
         (ob.cam_from_rig != nullptr ? kRig : 0u) | (ob.point_block != nullptr ? kPoint : 0u);
}

// The costs (blocks in the layout's order); defined in bundle.cc, bundle_port.cc and, for a free
// target behind a port, bundle_port_point.cc.
ceres::CostFunction* NewCentralCost(const BundleCamera& c, const BundleObservation& ob, Form form);
ceres::CostFunction* NewPortCost(const BundleCamera& c, const BundleObservation& ob);
ceres::CostFunction* NewPortPointCost(const BundleCamera& c, const BundleObservation& ob);

// The AutoDiff cost of layout kB (block sizes after the lens: kSizes).
template <typename M, unsigned kB, int... kSizes>
ceres::CostFunction* AutoCost(const BundleCamera& c, const BundleObservation& ob) {
  return new ceres::AutoDiffCostFunction<BundleResidual<M, kB>, 2, M::kNumParams, kSizes...>(
      new BundleResidual<M, kB>(ResidualOf<M, kB>(c, ob)));
}

}  // namespace porthole::calib::bundle_detail
