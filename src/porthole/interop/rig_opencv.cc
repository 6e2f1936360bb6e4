// OpenCV's stereo calibration file, FileStorage YAML (rig format opencv-stereo) or XML
// (opencv-stereo-xml): K1 D1 K2 D2 R T as cv::stereoCalibrate returns them and cv::stereoRectify
// takes them (OpenCV's calib3d documentation), with image_width, image_height and porthole's T_unit;
// docs/interop.md, "Rig files".
#include <fmt/format.h>

#include <Eigen/Core>
#include <algorithm>

#include "porthole/core/error.h"
#include "porthole/interop/rig_internal.h"
#include "porthole/interop/xml.h"

namespace porthole::interop::detail {
namespace {

using camera::Camera;
using camera::CameraModelId;

std::string WriteOpenCVStereo(const RigFile& rig, bool xml, const std::string& field, std::vector<RigWriteCamera>* info) {
  const RigFormat format = xml ? RigFormat::kOpenCVStereoXml : RigFormat::kOpenCVStereoYaml;
  const PairCameras p = OpenCVPair(rig, format, field);
  const auto [r, t] = Relative(rig.cameras[0], rig.cameras[1]);
  const int n1 = std::max(OpenCVCount(p.first.cam), 5), n2 = std::max(OpenCVCount(p.second.cam), 5);  // as cv::stereoCalibrate: 5 or 8
  const Eigen::Matrix3d rt = r.transpose();  // its column-major data: R row-major
  const std::vector<double> rv(rt.data(), rt.data() + 9);
  const std::vector<double> tv{t(0), t(1), t(2)};
  const auto matrix = [&](std::string_view name, int rows, int cols, const std::vector<double>& values) {
    if (xml) {
      return fmt::format("<{0} type_id=\"opencv-matrix\">\n  <rows>{1}</rows>\n  <cols>{2}</cols>\n  <dt>d</dt>\n"
                         "  <data>\n    {3}</data></{0}>\n",
                         name, rows, cols, NumList(values, " "));
    }
    return fmt::format("{}: !!opencv-matrix\n   rows: {}\n   cols: {}\n   dt: d\n   data: [ {} ]\n", name, rows, cols,
                       NumList(values));
  };
  const std::string body = matrix("K1", 3, 3, KMatrix(p.first.cam)) + matrix("D1", n1, 1, Coefficients(p.first.cam, n1)) +
                           matrix("K2", 3, 3, KMatrix(p.second.cam)) +
                           matrix("D2", n2, 1, Coefficients(p.second.cam, n2)) + matrix("R", 3, 3, rv) +
                           matrix("T", 3, 1, tv);
  std::string comment = fmt::format("porthole rig: {} (K1 D1) and {} (K2 D2); x2 = R x1 + T, T in mm",
                                    rig.cameras[0].name, rig.cameras[1].name);
  for (char& ch : comment) {
    if (ch == '\n' || ch == '-') ch = ' ';
  }
  for (const auto* f : {&p.first, &p.second}) {
    info->push_back({f == &p.first ? rig.cameras[0].name : rig.cameras[1].name,
                     fmt::format("{} coefficients", f == &p.first ? n1 : n2), f->exact, f->fit});
  }
  const auto& s = p.first.cam.sensor;
  if (xml) {
    return fmt::format("<?xml version=\"1.0\"?>\n<opencv_storage>\n<!-- {} -->\n<image_width>{}</image_width>\n"
                       "<image_height>{}</image_height>\n{}<T_unit>\"mm\"</T_unit>\n</opencv_storage>\n",
                       comment, s.width_px, s.height_px, body);
  }
  return fmt::format("%YAML:1.0\n---\n# {}\nimage_width: {}\nimage_height: {}\n{}T_unit: \"mm\"\n", comment, s.width_px,
                     s.height_px, body);
}

RigFile ReadOpenCVStereo(const std::string& text, bool xml, const RigReadOptions& o, const std::string& field) {
  YNode root;
  if (xml) {
    const XmlDocument doc = ParseXml(text, field);
    if (doc.root().name != "opencv_storage") throw InvalidInput(field, "not an OpenCV FileStorage XML (no <opencv_storage>)");
    root = XmlToNode(doc, doc.root());
  } else {
    root = ParseYaml(text, field);
  }
  if (root.kind != YNode::kMap) throw InvalidInput(field, "not an OpenCV stereo file: no K1, D1, K2, D2, R, T");
  int w = 0, h = 0;
  if (const YNode* size = root.Get("image_size"); size != nullptr) {
    const auto v = Matrix(*size, 2, field + ": image_size");
    w = PixelsValue(v[0], field + ": image_size");
    h = PixelsValue(v[1], field + ": image_size");
  } else {
    w = Pixels(Need(root, "image_width", field), field + ": image_width");
    h = Pixels(Need(root, "image_height", field), field + ": image_height");
  }
  const auto camera = [&](const char* k, const char* d) {
    const auto km = CheckCameraMatrix(Matrix(Need(root, k, field), 9, field + ": " + k), field + ": " + k);
    const auto dv = CheckOpenCVDistortion(Matrix(Need(root, d, field), 0, field + ": " + d), field + ": " + d);
    return PixelOpenCV(w, h, o.pixel_pitch_mm, km, dv);
  };
  const Camera c1 = camera("K1", "D1"), c2 = camera("K2", "D2");
  const Eigen::Matrix3d r = Rotation(Matrix(Need(root, "R", field), 9, field + ": R"), field + ": R");
  const auto tv = Matrix(Need(root, "T", field), 3, field + ": T");
  RigFile tmp;
  const double mm = TUnitMm(root.Get("T_unit"), o, field, &tmp);
  RigFile rig = PairRig(c1, c2, r, Eigen::Vector3d(tv[0], tv[1], tv[2]) * mm, "camera1", "camera2");
  rig.length_unit_note = tmp.length_unit_note;
  rig.format = xml ? RigFormat::kOpenCVStereoXml : RigFormat::kOpenCVStereoYaml;
  return rig;
}

}  // namespace

RigFile ReadOpenCVStereoFile(const std::vector<std::string>& contents, const std::vector<std::string>& /*names*/,
                             RigFormat format, const RigReadOptions& options, const std::string& field) {
  return ReadOpenCVStereo(contents[0], format == RigFormat::kOpenCVStereoXml, options, field);
}

RigFiles WriteOpenCVStereoFile(const RigFile& rig, RigFormat format, const std::string& field,
                               std::vector<RigWriteCamera>* info) {
  return {{"", WriteOpenCVStereo(rig, format == RigFormat::kOpenCVStereoXml, field, info)}};
}

}  // namespace porthole::interop::detail
