// Scenes the render tests share (render_test, coded_render_test). Tests only.
#pragma once

#include <variant>

#include "porthole/io/presets.h"
#include "porthole/ports/port.h"

namespace porthole::render::testing {

// The 8" dome made concentric and centred on the pupil (a cam-frame port, no rim): no ray is bent,
// the camera alone.
inline ports::PortSpec ConcentricDome() {
  ports::PortSpec dome = io::LoadPort("generic-dome-8in");
  ports::DomePort shape = std::get<ports::DomePort>(dome.shape);
  dome.frame = ports::PortFrame::kCam;
  shape.outer.center_mm = shape.inner.center_mm = Eigen::Vector3d::Zero();
  shape.rim_z_mm.reset();
  dome.shape = shape;
  return dome;
}

}  // namespace porthole::render::testing
