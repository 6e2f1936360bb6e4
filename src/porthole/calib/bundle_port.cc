// The costs of bundle.h for cameras behind a port (apart from bundle.cc: the automatic derivatives
// through the port are the heaviest code to compile, and two units build in parallel).
#include "porthole/calib/bundle_residual.h"
#include "porthole/core/error.h"

namespace porthole::calib::bundle_detail {

ceres::CostFunction* NewPortCost(const BundleCamera& c, const BundleObservation& ob) {
  constexpr int P = refraction::kPortNumParams;
  constexpr int S = refraction::kShellNumParams;
  return camera::VisitModel(c.model, [&](auto m) -> ceres::CostFunction* {
    using M = decltype(m);
    const unsigned layout = LayoutOf(c, ob);
    if ((layout & kPoint) != 0) return NewPortPointCost(c, ob);
    switch (layout) {
      case kPort: return AutoCost<M, kPort, P, 6>(c, ob);
      case kPort | kShell: return AutoCost<M, kPort | kShell, P, S, 6>(c, ob);
      case kPort | kRig: return AutoCost<M, kPort | kRig, P, 6, 6>(c, ob);
      case kPort | kFocus: return AutoCost<M, kPort | kFocus, 1, P, 6>(c, ob);
      case kPort | kShell | kFocus: return AutoCost<M, kPort | kShell | kFocus, 1, P, S, 6>(c, ob);
      default: throw InternalError("bundle: a port with this layout (rig shell values, a refocused rig set) is not supported yet");
    }
  });
}

}  // namespace porthole::calib::bundle_detail
