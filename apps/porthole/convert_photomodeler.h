// `porthole convert EXPORT.txt [CONTROL.txt] DETECTIONS.json --to detections --field-out FIELD.txt`:
// a PhotoModeler text export (and DBAT's control-point file) as porthole detections and a target
// field, for `porthole calibrate --detections … --field …` (interop/photomodeler.h, docs/interop.md).
#pragma once

#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace porthole::cli {

// ins: the export, then optionally the control-point file; out: the detection-set JSON.
void RunPhotoModelerConvert(const std::vector<std::string>& ins, const std::string& out, const std::string& field_out,
                            std::optional<std::pair<int, int>> image_size_px, bool json, bool force);

}  // namespace porthole::cli
