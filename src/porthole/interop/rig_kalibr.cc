// Kalibr's camchain YAML (rig format kalibr): cam0, cam1, … each with camera_model pinhole,
// intrinsics [fu fv pu pv], distortion_model radtan / equidistant / none, distortion_coeffs,
// resolution, rostopic and T_cn_cnm1 (camera n−1's frame into camera n's, metres), as Kalibr's
// kalibr_calibrate_cameras writes it (its wiki, "Yaml formats"; docs/interop.md, "Rig files").
#include <fmt/format.h>

#include <Eigen/Core>
#include <cctype>

#include "porthole/core/error.h"
#include "porthole/interop/rig_internal.h"

namespace porthole::interop::detail {
namespace {

using camera::Camera;
using camera::CameraModelId;

std::string WriteKalibr(const RigFile& rig, const std::string& field, std::vector<RigWriteCamera>* info) {
  RequireNoPort(rig, RigFormat::kKalibr, field);
  if (rig.cameras.empty()) throw InvalidInput(field, "the rig has no camera");
  std::string out = "# porthole rig (Kalibr camchain): T_cn_cnm1 takes camera n-1's frame into camera n's, metres\n";
  for (std::size_t k = 0; k < rig.cameras.size(); ++k) {
    const auto& c = rig.cameras[k];
    const std::string f = field + ": camera " + c.name;
    Fitted fit;
    std::string dist;
    if (const auto kb = AsKB(c.calibration.camera, f)) {
      fit = {*kb, true, {}};
      dist = "equidistant";
    } else {
      fit = AsOpenCV(c.calibration.camera, 4, f);
      dist = "radtan";
    }
    info->push_back({c.name, "pinhole-" + dist, fit.exact, fit.fit});
    const auto& p = fit.cam.params;
    out += fmt::format("cam{}:\n", k);
    if (k > 0) {
      const auto [r, t] = Relative(rig.cameras[k - 1], c);
      out += "  T_cn_cnm1:\n";
      for (int a = 0; a < 3; ++a) out += fmt::format("  - [{}]\n", NumList({r(a, 0), r(a, 1), r(a, 2), t(a) / 1000}));
      out += "  - [0.0, 0.0, 0.0, 1.0]\n";
    }
    std::string topic = c.name;
    for (char& ch : topic) {
      if (!std::isalnum(static_cast<unsigned char>(ch)) && ch != '_') ch = '_';
    }
    out += fmt::format("  camera_model: pinhole\n  distortion_coeffs: [{}]\n  distortion_model: {}\n  intrinsics: [{}]\n"
                       "  resolution: [{}, {}]\n  rostopic: /{}/image_raw\n",
                       NumList(Coefficients(fit.cam, 4)), dist, NumList({p[0], p[1], p[2], p[3]}),
                       fit.cam.sensor.width_px, fit.cam.sensor.height_px, topic);
  }
  return out;
}

RigFile ReadKalibr(const std::string& text, const RigReadOptions& o, const std::string& field) {
  const YNode root = ParseYaml(text, field);
  if (root.kind != YNode::kMap || root.Get("cam0") == nullptr) throw InvalidInput(field + ": cam0", "missing: not a Kalibr camchain");
  RigFile rig;
  rig.format = RigFormat::kKalibr;
  rig.length_unit_note = "metres (Kalibr)";
  for (int k = 0;; ++k) {
    const std::string key = fmt::format("cam{}", k);
    const YNode* c = root.Get(key);
    if (c == nullptr) break;
    const std::string f = field + ": " + key;
    if (c->kind != YNode::kMap) throw InvalidInput(f, "must be a mapping");
    const YNode& model = Need(*c, "camera_model", f);
    if (model.scalar != "pinhole") {
      throw InvalidInput(f + ".camera_model", "'" + model.scalar.substr(0, 40) + "' is not read (pinhole; omni, eucm and ds have no "
                                                                                 "porthole model)");
    }
    const auto in = Matrix(Need(*c, "intrinsics", f), 4, f + ".intrinsics");
    if (!(in[0] > 0 && in[1] > 0)) throw InvalidInput(f + ".intrinsics", "fu and fv must be > 0");
    const auto res = Matrix(Need(*c, "resolution", f), 2, f + ".resolution");
    const int w = PixelsValue(res[0], f + ".resolution"), h = PixelsValue(res[1], f + ".resolution");
    const std::string dist = Need(*c, "distortion_model", f).scalar;
    const auto d = Matrix(Need(*c, "distortion_coeffs", f), 0, f + ".distortion_coeffs");
    const std::vector<double> km{in[0], 0, in[2], 0, in[1], in[3], 0, 0, 1};
    Camera cam;
    if (dist == "radtan" || dist == "none") {
      const std::size_t n = dist == "radtan" ? 4 : 0;
      if (d.size() != n) throw InvalidInput(f + ".distortion_coeffs", fmt::format("{} holds {} coefficients, not {}", dist, n, d.size()));
      cam = PixelOpenCV(w, h, o.pixel_pitch_mm, km, d);
    } else if (dist == "equidistant") {
      if (d.size() != 4) throw InvalidInput(f + ".distortion_coeffs", fmt::format("equidistant holds 4 coefficients, not {}", d.size()));
      cam = PixelKB(w, h, o.pixel_pitch_mm, km, d);
    } else {
      throw InvalidInput(f + ".distortion_model", "'" + dist.substr(0, 40) + "' is not read (radtan, equidistant, none)");
    }
    std::string name = key;
    if (const YNode* topic = c->Get("rostopic"); topic != nullptr && topic->kind == YNode::kScalar) {
      std::string t = topic->scalar;
      if (t.size() > 10 && t.substr(t.size() - 10) == "/image_raw") t.resize(t.size() - 10);
      while (!t.empty() && t.front() == '/') t.erase(t.begin());
      if (!t.empty() && t.find('/') == std::string::npos) name = t;
    }
    RigFileCamera rc = Camera1(name, cam);
    if (k > 0) {
      const auto m = Matrix(Need(*c, "T_cn_cnm1", f), 16, f + ".T_cn_cnm1");
      if (m[12] != 0 || m[13] != 0 || m[14] != 0 || m[15] != 1) {
        throw InvalidInput(f + ".T_cn_cnm1", "the last row must be [0, 0, 0, 1]");
      }
      const Eigen::Matrix3d r = Rotation({m[0], m[1], m[2], m[4], m[5], m[6], m[8], m[9], m[10]}, f + ".T_cn_cnm1");
      const Eigen::Vector3d t = Eigen::Vector3d(m[3], m[7], m[11]) * 1000;
      const auto& prev = rig.cameras.back();
      rc.rotation = r * prev.rotation;
      rc.translation_mm = r * prev.translation_mm + t;
    }
    rig.cameras.push_back(std::move(rc));
  }
  return rig;
}

}  // namespace

RigFile ReadKalibrFile(const std::vector<std::string>& contents, const std::vector<std::string>& /*names*/,
                       RigFormat /*format*/, const RigReadOptions& options, const std::string& field) {
  return ReadKalibr(contents[0], options, field);
}

RigFiles WriteKalibrFile(const RigFile& rig, RigFormat /*format*/, const std::string& field,
                         std::vector<RigWriteCamera>* info) {
  return {{"", WriteKalibr(rig, field, info)}};
}

}  // namespace porthole::interop::detail
