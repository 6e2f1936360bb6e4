// Bundle (bundle.h): the problem, the held parameters, the Schur ordering, the solve; the costs of
// central cameras (those behind a port: bundle_port.cc).
#include "porthole/calib/bundle.h"

#include <memory>
#include <set>
#include <utility>

#include "porthole/calib/bundle_residual.h"
#include "porthole/calib/residual.h"
#include "porthole/camera/sensor.h"
#include "porthole/core/error.h"

namespace porthole::calib {
namespace bundle_detail {
namespace {

// A cost over (camera, rotation [3], translation [3][, point [3]]) seen as (camera, pose [6]
// [, point]): one pose block per image. Ceres's Schur solvers eliminate an independent set of
// blocks; with the rotation and the translation apart (one residual touches both) only one of
// the two left each image, the reduced system grew by 3 per image and the solve as n^2.5 (issue
// 26: 2.95 s at 1,000 views). With one block per pose every pose is eliminated and the reduced
// system is the camera's N × N: a solve linear in the images.
class PoseBlockCost final : public ceres::CostFunction {
 public:
  explicit PoseBlockCost(ceres::CostFunction* inner) : inner_(inner) {
    const std::vector<int32_t>& in = inner->parameter_block_sizes();
    set_num_residuals(inner->num_residuals());
    auto* sizes = mutable_parameter_block_sizes();
    *sizes = {in[0], 6};
    if (in.size() > 3) sizes->push_back(in[3]);
  }

  bool Evaluate(double const* const* p, double* residuals, double** jacobians) const override {
    const bool with_point = parameter_block_sizes().size() > 2;
    const double* q[] = {p[0], p[1], p[1] + 3, with_point ? p[2] : nullptr};
    if (jacobians == nullptr) return inner_->Evaluate(q, residuals, nullptr);
    constexpr int kMaxResiduals = 2;
    std::array<double, kMaxResiduals * 3> jr, jt;
    double* j[] = {jacobians[0], jacobians[1] ? jr.data() : nullptr, jacobians[1] ? jt.data() : nullptr,
                   with_point ? jacobians[2] : nullptr};
    if (!inner_->Evaluate(q, residuals, j)) return false;
    if (jacobians[1] != nullptr) {
      for (int row = 0; row < num_residuals(); ++row) {
        for (int c = 0; c < 3; ++c) {
          jacobians[1][row * 6 + c] = jr[row * 3 + c];
          jacobians[1][row * 6 + 3 + c] = jt[row * 3 + c];
        }
      }
    }
    return true;
  }

 private:
  std::unique_ptr<ceres::CostFunction> inner_;
};

// The Brown model's analytic cost (residual.h) in the form `form`, as (lens, pose [6][, point]).
template <bool kPointFree>
ceres::CostFunction* NewAnalytic(Form form, const BundleCamera& c, const BundleObservation& ob) {
  CameraScales scale;
  std::copy(c.scale.begin(), c.scale.end(), scale.begin());
  const Eigen::Vector2d xy = camera::PixelToImageMm(c.sensor, ob.u_px, ob.v_px);
  const double pitch = c.sensor.pixel_pitch_mm;
  if (form == Form::kProject) {
    return new PoseBlockCost(new AnalyticResidual<Form::kProject, kPointFree>(xy.x(), xy.y(), pitch, scale, ob.point));
  }
  return new PoseBlockCost(new AnalyticResidual<Form::kCorrect, kPointFree>(xy.x(), xy.y(), pitch, scale, ob.point));
}

}  // namespace

ceres::CostFunction* NewCentralCost(const BundleCamera& c, const BundleObservation& ob, Form form) {
  const unsigned layout = LayoutOf(c, ob);
  return camera::VisitModel(c.model, [&](auto m) -> ceres::CostFunction* {
    using M = decltype(m);
    if constexpr (M::kCaps.analytic_jacobian) {
      // The analytic Jacobian where it is known: a single camera (the rig's offset is not in it).
      if (layout == 0 && ob.weight == 1) return NewAnalytic<false>(form, c, ob);
      if (layout == kPoint && ob.weight == 1) return NewAnalytic<true>(form, c, ob);
    }
    switch (layout) {
      case 0: return AutoCost<M, 0, 6>(c, ob);
      case kPoint: return AutoCost<M, kPoint, 6, 3>(c, ob);
      case kRig: return AutoCost<M, kRig, 6, 6>(c, ob);
      case kRig | kPoint: return AutoCost<M, kRig | kPoint, 6, 6, 3>(c, ob);
      default: throw InternalError("bundle: a central camera with this layout (a refocused set) is not supported yet");
    }
  });
}

}  // namespace bundle_detail

ceres::CostFunction* NewObservationCost(const BundleCamera& c, const BundleObservation& ob, Form form) {
  return c.port != nullptr ? bundle_detail::NewPortCost(c, ob) : bundle_detail::NewCentralCost(c, ob, form);
}

namespace {

// An observation's blocks in the cost's order (NewObservationCost).
std::vector<double*> BlocksOf(const BundleCamera& c, const BundleObservation& ob) {
  std::vector<double*> blocks = {c.scaled};
  if (ob.focal_scale != nullptr) blocks.push_back(ob.focal_scale);
  if (c.port != nullptr) blocks.push_back(c.port);
  if (c.port != nullptr && c.shell_values != nullptr) blocks.push_back(c.shell_values);
  if (ob.cam_from_rig != nullptr) blocks.push_back(ob.cam_from_rig);
  blocks.push_back(ob.pose);
  if (ob.point_block != nullptr) blocks.push_back(ob.point_block);
  return blocks;
}

}  // namespace

std::optional<Eigen::Vector2d> ObservationResidual(const BundleCamera& c, const BundleObservation& ob) {
  const std::unique_ptr<ceres::CostFunction> cost(NewObservationCost(c, ob));
  const std::vector<double*> blocks = BlocksOf(c, ob);
  double r[2];
  if (!cost->Evaluate(blocks.data(), r, nullptr)) return std::nullopt;
  return Eigen::Vector2d(r[0], r[1]);
}

Bundle::Bundle(LossKind loss, double loss_scale_px, Form form)
    : loss_(loss), loss_scale_px_(loss_scale_px), form_(form), problem_(std::make_unique<ceres::Problem>()) {}

Bundle::~Bundle() = default;

int Bundle::AddCamera(const BundleCamera& camera) {
  cameras_.push_back(camera);
  return static_cast<int>(cameras_.size()) - 1;
}

void Bundle::AddObservation(const BundleObservation& ob) {
  const BundleCamera& c = cameras_.at(ob.camera);
  const std::vector<double*> blocks = BlocksOf(c, ob);
  ceres::LossFunction* loss = nullptr;
  if (loss_ == LossKind::kHuber) loss = new ceres::HuberLoss(loss_scale_px_);
  if (loss_ == LossKind::kCauchy) loss = new ceres::CauchyLoss(loss_scale_px_);
  problem_->AddResidualBlock(NewObservationCost(c, ob, form_), loss, blocks);
  poses_.insert(ob.pose);
  if (ob.point_block != nullptr) points_.insert(ob.point_block);
}

void Bundle::AddCost(ceres::CostFunction* cost, const std::vector<double*>& blocks) {
  problem_->AddResidualBlock(cost, nullptr, blocks);
}

void Bundle::HoldPoint(double* point_block, const std::vector<int>& held) {
  if (!problem_->HasParameterBlock(point_block)) return;
  if (held.empty() || held.size() == 3) {
    problem_->SetParameterBlockConstant(point_block);
  } else {
    problem_->SetManifold(point_block, new ceres::SubsetManifold(3, held));
  }
}

namespace {

// Holds the parameters `free[i]` false of a block (all of them: the whole block).
template <typename Free>
void HoldSubset(ceres::Problem* problem, double* block, const Free& free) {
  if (block == nullptr || !problem->HasParameterBlock(block)) return;
  std::vector<int> fixed;
  for (std::size_t i = 0; i < free.size(); ++i) {
    if (!free[i]) fixed.push_back(static_cast<int>(i));
  }
  if (fixed.size() == free.size()) {
    problem->SetParameterBlockConstant(block);
  } else if (!fixed.empty()) {
    problem->SetManifold(block, new ceres::SubsetManifold(static_cast<int>(free.size()), fixed));
  }
}

}  // namespace

void Bundle::Seal() {
  if (sealed_) return;
  sealed_ = true;
  std::set<double*> done;  // cameras may share a block (one lens in two media)
  for (const BundleCamera& c : cameras_) {
    if (!done.insert(c.scaled).second) continue;
    HoldSubset(problem_.get(), c.scaled, c.free);
    if (c.port != nullptr) HoldSubset(problem_.get(), c.port, c.port_free);
    if (c.port != nullptr && c.shell_values != nullptr) HoldSubset(problem_.get(), c.shell_values, c.shell_free);
  }
}

ceres::Problem& Bundle::problem() {
  Seal();
  return *problem_;
}

ceres::Solver::Summary Bundle::Solve(const BundleSolveOptions& o) {
  Seal();
  ceres::Solver::Options so;
  so.logging_type = ceres::SILENT;  // no Ceres lines on stderr (issue 24)
  so.linear_solver_type = o.sparse ? ceres::SPARSE_SCHUR : ceres::DENSE_SCHUR;
  so.max_num_iterations = o.max_iterations;
  // A step that carries a point beyond a model's valid field (a fisheye's fold) or the port's rim
  // cannot be evaluated; Ceres then shrinks the trust region. Its default gives up after 5 such
  // steps in a row, before the region is small enough.
  so.max_num_consecutive_invalid_steps = 50;
  so.initial_trust_region_radius = o.initial_trust_region_radius;
  so.function_tolerance = o.function_tolerance;
  so.parameter_tolerance = o.parameter_tolerance;
  so.gradient_tolerance = o.gradient_tolerance;
  so.num_threads = o.num_threads;
  // The Schur complement eliminates the free target points (when there are) or else the poses:
  // the reduced system is the cameras' (lenses, ports, rig offsets) and, with a free target, the poses'.
  auto ordering = std::make_shared<ceres::ParameterBlockOrdering>();
  std::vector<double*> blocks;
  problem_->GetParameterBlocks(&blocks);
  for (double* b : blocks) {
    const bool eliminated = points_.empty() ? poses_.count(b) > 0 : points_.count(b) > 0;
    ordering->AddElementToGroup(b, eliminated ? 0 : 1);
  }
  so.linear_solver_ordering = ordering;
  ceres::Solver::Summary summary;
  ceres::Solve(so, problem_.get(), &summary);
  return summary;
}

}  // namespace porthole::calib
