// The costs of bundle.h for a free target seen through a port (its points adjusted: the refractive
// calibration's and the rig's self-calibration, issue 26); apart from bundle_port.cc so that the two heaviest
// units of automatic derivatives through the port build in parallel.
#include "porthole/calib/bundle_residual.h"
#include "porthole/core/error.h"

namespace porthole::calib::bundle_detail {

ceres::CostFunction* NewPortPointCost(const BundleCamera& c, const BundleObservation& ob) {
  constexpr int P = refraction::kPortNumParams;
  constexpr int S = refraction::kShellNumParams;
  return camera::VisitModel(c.model, [&](auto m) -> ceres::CostFunction* {
    using M = decltype(m);
    switch (LayoutOf(c, ob)) {
      case kPort | kPoint: return AutoCost<M, kPort | kPoint, P, 6, 3>(c, ob);
      case kPort | kShell | kPoint: return AutoCost<M, kPort | kShell | kPoint, P, S, 6, 3>(c, ob);
      case kPort | kFocus | kPoint: return AutoCost<M, kPort | kFocus | kPoint, 1, P, 6, 3>(c, ob);
      case kPort | kShell | kFocus | kPoint:
        return AutoCost<M, kPort | kShell | kFocus | kPoint, 1, P, S, 6, 3>(c, ob);
      case kPort | kRig | kPoint: return AutoCost<M, kPort | kRig | kPoint, P, 6, 6, 3>(c, ob);
      default: throw InternalError("bundle: a rig camera behind a port with shell values and a free target is not "
                                   "supported yet");
    }
  });
}

}  // namespace porthole::calib::bundle_detail
