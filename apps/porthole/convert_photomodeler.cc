// PhotoModeler's text export → porthole detections and target field (convert_photomodeler.h).
#include "convert_photomodeler.h"

#include <fmt/format.h>

#include "common.h"
#include "porthole/calib/detections_json.h"
#include "porthole/calib/target.h"
#include "porthole/core/error.h"
#include "porthole/core/output.h"
#include "porthole/interop/photomodeler.h"

namespace porthole::cli {

void RunPhotoModelerConvert(const std::vector<std::string>& ins, const std::string& out, const std::string& field_out,
                            std::optional<std::pair<int, int>> image_size_px, bool json, bool force) {
  if (ins.size() > 2) throw InvalidInput("IN", "--to detections reads one PhotoModeler export and at most one control-point file");
  if (field_out.empty()) throw InvalidInput("--field-out", "--to detections needs the field file to write (the 3-D points)");
  interop::PhotoModelerOptions opt;
  opt.image_size_px = image_size_px;
  interop::PhotoModelerProject p = interop::ReadPhotoModelerExport(ins[0], opt, "IN");
  if (ins.size() == 2) interop::ApplyControlPoints(interop::ReadDbatControlPoints(ins[1], "IN"), &p, "IN");
  const calib::TargetSpec target = calib::ParseTarget(interop::kPhotoModelerTarget);
  const std::string detections = calib::DetectionSetToJson(p.detections, {}, target).dump(1) + "\n";
  const std::string field = interop::FieldFileText(p, ins[0]);

  OutputRules rules{.force = force, .inputs = {}};
  for (const auto& path : ins) rules.inputs.emplace_back(path);
  CheckOutput(out, "OUT", rules, FileKind::kDetectionSet);
  CheckOutput(field_out, "--field-out", rules);
  WriteOutput(out, detections, "OUT", rules);
  WriteOutput(field_out, field, "--field-out", rules);

  const interop::BrownFromPhotoModeler b = interop::BrownCamera(p);
  int n_control = 0;
  for (const auto& q : p.field) n_control += q.control;
  const std::string next = fmt::format("porthole calibrate --detections {} --field {} --free-target --pixel-pitch-mm {:.8g} "
                                       "--centre-correction off", out, field_out, b.pixel_pitch_mm);
  if (json) {
    Json j = {{"in", ins},
              {"in_format", "photomodeler"},
              {"title", p.title},
              {"out", out},
              {"field_out", field_out},
              {"n_images", p.detections.size()},
              {"n_image_points", p.n_marks},
              {"n_points", p.field.size()},
              {"n_control_points", n_control},
              {"width_px", p.width_px},
              {"height_px", p.height_px},
              {"camera", {{"pixel_pitch_mm", b.pixel_pitch_mm}, {"c_mm", b.c_mm}, {"x0_mm", b.x0_mm}, {"y0_mm", b.y0_mm},
                          {"K1", b.K1}, {"K2", b.K2}, {"K3", b.K3}, {"P1", b.P1}, {"P2", b.P2}}},
              {"next", next}};
    return fmt::print("{}\n", PrintableJson(j));
  }
  fmt::print("{} (PhotoModeler, '{}'): {} images, {} image points -> {}; {} points ({} control) -> {}\n", ins[0], p.title,
             p.detections.size(), p.n_marks, out, p.field.size(), n_control, field_out);
  fmt::print("its camera in porthole's convention: c {:.4f} mm, x0 {:.4f} mm, y0 {:.4f} mm, pitch {:.8g} mm "
             "(K1 {:.4g}, K2 {:.4g}, K3 {:.4g}, P1 {:.4g}, P2 {:.4g})\n",
             b.c_mm, b.x0_mm, b.y0_mm, b.pixel_pitch_mm, b.K1, b.K2, b.K3, b.P1, b.P2);
  fmt::print("next: {}\n", next);
}

}  // namespace porthole::cli
