// The costs of bundle.h for cameras behind a port (apart from bundle.cc: the automatic derivatives
// through the port are the heaviest code to compile, and two units build in parallel).
#include "porthole/calib/bundle_residual.h"
#include "porthole/core/error.h"

namespace porthole::calib::bundle_detail {
namespace {

template <typename M, unsigned kB, int... kSizes>
ceres::CostFunction* Auto(const BundleCamera& c, const BundleObservation& ob) {
  return new ceres::AutoDiffCostFunction<BundleResidual<M, kB>, 2, M::kNumParams, kSizes...>(
      new BundleResidual<M, kB>(ResidualOf<M, kB>(c, ob)));
}

}  // namespace

ceres::CostFunction* NewPortCost(const BundleCamera& c, const BundleObservation& ob) {
  constexpr int P = refraction::kPortNumParams;
  constexpr int S = refraction::kShellNumParams;
  return camera::VisitModel(c.model, [&](auto m) -> ceres::CostFunction* {
    using M = decltype(m);
    switch (LayoutOf(c, ob)) {
      case kPort: return Auto<M, kPort, P, 6>(c, ob);
      case kPort | kShell: return Auto<M, kPort | kShell, P, S, 6>(c, ob);
      case kPort | kRig: return Auto<M, kPort | kRig, P, 6, 6>(c, ob);
      case kPort | kFocus: return Auto<M, kPort | kFocus, 1, P, 6>(c, ob);
      case kPort | kShell | kFocus: return Auto<M, kPort | kShell | kFocus, 1, P, S, 6>(c, ob);
      default: throw InternalError("bundle: a port with this layout (rig shell values or a free target) is not supported yet");
    }
  });
}

}  // namespace porthole::calib::bundle_detail
