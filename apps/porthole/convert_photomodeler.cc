// PhotoModeler's text export → porthole detections and target field (convert_photomodeler.h).
#include "convert_photomodeler.h"

#include <fmt/format.h>

#include "common.h"
#include "porthole/calib/detections_json.h"
#include "porthole/calib/target.h"
#include "porthole/core/error.h"
#include "porthole/core/input.h"
#include "porthole/core/output.h"
#include "porthole/interop/photomodeler.h"

namespace porthole::cli {

void RunPhotoModelerConvert(const std::vector<std::string>& ins, const std::string& out, const std::string& field_out,
                            std::optional<std::pair<int, int>> image_size_px, bool json, bool force) {
  if (field_out.empty()) throw InvalidInput("--field-out", "--to detections needs the field file to write (the 3-D points)");
  interop::PhotoModelerOptions opt;
  opt.image_size_px = image_size_px;
  // The INs: the export, or the 2-D and 3-D point tables (either order); then a control-point file.
  std::vector<int> kinds;
  for (const auto& path : ins) kinds.push_back(interop::PhotoModelerTableKind(ReadInputFile(path, "IN", kMaxJsonFileBytes)));
  const bool tables = kinds[0] != 0;
  const std::size_t n_project = tables ? 2 : 1;
  if (tables && (ins.size() < 2 || kinds[0] + kinds[1] != 5)) {
    throw InvalidInput("IN", "PhotoModeler's point tables come in pairs: the 2-D table (Object Point ID,Photo #,...) "
                             "and the 3-D table (Id,Name,...)");
  }
  if (ins.size() > n_project + 1) {
    throw InvalidInput("IN", "--to detections reads one PhotoModeler export (or its two point tables) and at most one "
                             "control-point file");
  }
  interop::PhotoModelerProject p = !tables        ? interop::ReadPhotoModelerExport(ins[0], opt, "IN")
                                   : kinds[0] == 2 ? interop::ReadPhotoModelerTables(ins[0], ins[1], opt, "IN")
                                                   : interop::ReadPhotoModelerTables(ins[1], ins[0], opt, "IN");
  if (ins.size() > n_project) interop::ApplyControlPoints(interop::ReadDbatControlPoints(ins.back(), "IN"), &p, "IN");
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
  const bool has_camera = p.camera.c_mm > 0;  // the point tables hold none
  const std::string pitch = has_camera ? fmt::format("{:.8g}", b.pixel_pitch_mm) : "PITCH_MM";
  const std::string next = fmt::format("porthole calibrate --detections {} --field {} --free-target --pixel-pitch-mm {} "
                                       "--centre-correction off", out, field_out, pitch);
  if (json) {
    Json j = {{"in", ins},
              {"in_format", "photomodeler"},
              {"title", p.title.empty() ? Json(nullptr) : Json(p.title)},
              {"out", out},
              {"field_out", field_out},
              {"n_images", p.detections.size()},
              {"n_image_points", p.n_marks},
              {"n_points", p.field.size()},
              {"n_control_points", n_control},
              {"width_px", p.width_px},
              {"height_px", p.height_px},
              {"camera", has_camera ? Json{{"pixel_pitch_mm", b.pixel_pitch_mm}, {"c_mm", b.c_mm}, {"x0_mm", b.x0_mm},
                                           {"y0_mm", b.y0_mm}, {"K1", b.K1}, {"K2", b.K2}, {"K3", b.K3}, {"P1", b.P1},
                                           {"P2", b.P2}}
                                     : Json(nullptr)},
              {"next", next}};
    return fmt::print("{}\n", PrintableJson(j));
  }
  fmt::print("{} (PhotoModeler{}): {} images, {} image points -> {}; {} points ({} control) -> {}\n", ins[0],
             p.title.empty() ? std::string() : ", '" + p.title + "'", p.detections.size(), p.n_marks, out, p.field.size(), n_control, field_out);
  if (has_camera) fmt::print("its camera in porthole's convention: c {:.4f} mm, x0 {:.4f} mm, y0 {:.4f} mm, pitch {:.8g} mm "
             "(K1 {:.4g}, K2 {:.4g}, K3 {:.4g}, P1 {:.4g}, P2 {:.4g})\n",
             b.c_mm, b.x0_mm, b.y0_mm, b.pixel_pitch_mm, b.K1, b.K2, b.K3, b.P1, b.P2);
  fmt::print("next: {}\n", next);
}

}  // namespace porthole::cli
