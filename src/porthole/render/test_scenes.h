// Scenes the render tests share (render_test, coded_render_test). Tests only.
#pragma once

#include <cstdint>
#include <string>
#include <variant>

#include "porthole/catalogue/presets.h"
#include "porthole/ports/port.h"
#include "porthole/render/render.h"

namespace porthole::render::testing {

// The paper's D300 + 24 mm behind `port`, its sensor reduced to width × (2/3 width) pixels of the
// same size in mm (small images keep the tests fast). Target, pose and medium are the caller's.
inline Scene PaperScene(const std::string& port, int width) {
  Scene s;
  s.housed.camera = catalogue::LoadCamera("nikon-d300");
  s.housed.lens = catalogue::LoadLens("nikkor-24mm-f2.8d");
  s.housed.port = catalogue::LoadPort(port);
  camera::Sensor& sensor = s.housed.camera.sensor;
  const double width_mm = sensor.width_px * sensor.pixel_pitch_mm;
  sensor = {width, width * 2 / 3, width_mm / width};
  return s;
}

// The 8" dome made concentric and centred on the pupil (a cam-frame port, no rim): no ray is bent,
// the camera alone.
inline ports::PortSpec ConcentricDome() {
  ports::PortSpec dome = catalogue::LoadPort("generic-dome-8in");
  ports::DomePort shape = std::get<ports::DomePort>(dome.shape);
  dome.frame = ports::PortFrame::kCam;
  shape.outer.center_mm = shape.inner.center_mm = Eigen::Vector3d::Zero();
  shape.rim_z_mm.reset();
  dome.shape = shape;
  return dome;
}

// Sharp edges for corner tests: one sample per pixel where the scene is flat, 144 (12 x 12) where a
// pixel or its neighbours differ; `seed` draws the samples.
inline RenderOptions EdgeSampling(std::uint64_t seed) {
  RenderOptions ro;
  ro.samples_per_pixel = 1;
  ro.edge_samples_per_pixel = 144;
  ro.seed = seed;
  return ro;
}

}  // namespace porthole::render::testing
