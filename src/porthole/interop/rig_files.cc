// Rig files of other tools (rig_files.h): OpenCV stereo, VIAME npz, ROS camera_info, Kalibr camchain.
#include "porthole/interop/rig_files.h"

#include <fmt/format.h>
#include <zip.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <memory>

#include "porthole/calib/rig.h"
#include "porthole/camera/validate.h"
#include "porthole/core/error.h"
#include "porthole/core/input.h"
#include "porthole/interop/interop.h"
#include "porthole/interop/pyliteral.h"
#include "porthole/interop/refit.h"
#include "porthole/interop/xml.h"
#include "porthole/interop/text.h"

namespace porthole::interop {
namespace {

using camera::Camera;
using camera::CameraModelId;
using OpenCV = camera::OpenCVModel;
using KB = camera::KannalaBrandtModel;
using Json = nlohmann::json;

constexpr std::size_t kMaxYamlLines = 100000;
constexpr int kMaxYamlDepth = 16;
constexpr std::size_t kMaxNpzMembers = 64;
constexpr std::size_t kMaxNpyBytes = 1u << 20;



// 17 significant digits, always with a decimal point (PyYAML reads "500" as an int and "1e-05" as a
// string; Kalibr's reader insists on floats).
std::string Float(double v) {
  std::string s = fmt::format("{:.17g}", v);
  if (s.find_first_of(".n") != std::string::npos) return s;  // has a point (or nan/inf: refused earlier)
  const auto e = s.find('e');
  if (e == std::string::npos) return s + ".0";
  return s.substr(0, e) + ".0" + s.substr(e);
}

// ---- A bounded reader of the YAML these files use: block mappings and sequences, flow sequences of
// scalars ([a, b], nested), scalars, comments, tags (!!opencv-matrix) and directives skipped. ----

struct YNode {
  enum Kind { kNull, kScalar, kSeq, kMap } kind = kNull;
  std::string scalar;
  std::vector<YNode> seq;
  std::vector<std::pair<std::string, YNode>> map;
  int line = 0;

  const YNode* Get(std::string_view key) const {
    for (const auto& [k, v] : map) {
      if (k == key) return &v;
    }
    return nullptr;
  }
};

struct YLine {
  int indent = 0;
  std::string text;
  int number = 0;
};

std::string StripComment(const std::string& s) {
  char quote = 0;
  for (std::size_t i = 0; i < s.size(); ++i) {
    const char c = s[i];
    if (quote) {
      if (c == quote) quote = 0;
    } else if (c == '"' || c == '\'') {
      if (i == 0 || s[i - 1] == ' ' || s[i - 1] == '[' || s[i - 1] == ',' || s[i - 1] == ':') quote = c;
    } else if (c == '#' && (i == 0 || s[i - 1] == ' ' || s[i - 1] == '\t')) {
      return s.substr(0, i);
    }
  }
  return s;
}

class YamlReader {
 public:
  YamlReader(std::string_view text, std::string field) : field_(std::move(field)) {
    std::size_t p = 0;
    int number = 0;
    while (p <= text.size()) {
      const std::size_t e = std::min(text.find('\n', p), text.size());
      std::string raw(text.substr(p, e - p));
      p = e + 1;
      ++number;
      if (number > static_cast<int>(kMaxYamlLines)) throw InvalidInput(field_, fmt::format("more than {} lines", kMaxYamlLines));
      std::string s = StripComment(raw);
      while (!s.empty() && (s.back() == '\r' || s.back() == ' ' || s.back() == '\t')) s.pop_back();
      if (s.empty() || s[0] == '%' || s == "---" || s == "...") continue;
      const auto ind = s.find_first_not_of(' ');
      if (s[ind] == '\t') throw InvalidInput(field_, fmt::format("line {}: a tab in the indentation", number));
      YLine l{static_cast<int>(ind), s.substr(ind), number};
      // A flow sequence over several lines (OpenCV writes long data: [ … ] so): join them.
      const auto depth = [](const std::string& t) {
        return std::count(t.begin(), t.end(), '[') - std::count(t.begin(), t.end(), ']');
      };
      while (depth(l.text) > 0 && p <= text.size()) {
        const std::size_t e2 = std::min(text.find('\n', p), text.size());
        l.text.push_back(' ');
        l.text.append(Trim(StripComment(std::string(text.substr(p, e2 - p)))));
        p = e2 + 1;
        ++number;
      }
      if (depth(l.text) != 0) throw InvalidInput(field_, fmt::format("line {}: unbalanced [ ]", l.number));
      lines_.push_back(std::move(l));
    }
  }

  YNode Parse() {
    std::size_t i = 0;
    if (lines_.empty()) throw InvalidInput(field_, "empty: no YAML content");
    YNode n = Block(i, lines_[0].indent, 0);
    if (i != lines_.size()) {
      throw InvalidInput(field_, fmt::format("line {}: unexpected indentation", lines_[i].number));
    }
    return n;
  }

 private:
  static bool IsDash(const YLine& l) { return l.text == "-" || l.text.rfind("- ", 0) == 0; }
  // The position of a mapping's ':' (followed by a space or the end), outside quotes and brackets.
  static std::size_t KeyColon(const std::string& t) {
    char quote = 0;
    int depth = 0;
    for (std::size_t i = 0; i < t.size(); ++i) {
      const char c = t[i];
      if (quote) {
        if (c == quote) quote = 0;
      } else if ((c == '"' || c == '\'') && i == 0) {
        quote = c;
      } else if (c == '[' || c == '{') {
        ++depth;
      } else if (c == ']' || c == '}') {
        --depth;
      } else if (c == ':' && depth == 0 && (i + 1 == t.size() || t[i + 1] == ' ')) {
        return i;
      }
    }
    return std::string::npos;
  }

  YNode Block(std::size_t& i, int indent, int depth) {
    if (depth > kMaxYamlDepth) throw InvalidInput(field_, fmt::format("line {}: nested deeper than {}", lines_[i].number, kMaxYamlDepth));
    YNode n;
    n.line = lines_[i].number;
    if (IsDash(lines_[i])) {
      n.kind = YNode::kSeq;
      while (i < lines_.size() && lines_[i].indent == indent && IsDash(lines_[i])) {
        YLine& l = lines_[i];
        const std::string rest = Trim(l.text.substr(1));
        if (rest.empty()) {
          ++i;
          if (i < lines_.size() && lines_[i].indent > indent) {
            n.seq.push_back(Block(i, lines_[i].indent, depth + 1));
          } else {
            YNode null;
            null.line = l.number;
            n.seq.push_back(null);
          }
        } else if (rest.rfind("- ", 0) == 0 || rest == "-" || (rest[0] != '[' && KeyColon(rest) != std::string::npos)) {
          // A compact nested item ("- - 1.0", "- key: value"): the rest is a block of its own.
          const int at = indent + static_cast<int>(l.text.size() - l.text.substr(1).size()) +
                         static_cast<int>(l.text.substr(1).find_first_not_of(' '));
          l.indent = at;
          l.text = rest;
          n.seq.push_back(Block(i, at, depth + 1));
        } else {
          n.seq.push_back(Inline(rest, l.number, depth));
          ++i;
        }
      }
      return n;
    }
    n.kind = YNode::kMap;
    while (i < lines_.size() && lines_[i].indent == indent && !IsDash(lines_[i])) {
      const YLine& l = lines_[i];
      const auto colon = KeyColon(l.text);
      if (colon == std::string::npos) {
        throw InvalidInput(field_, fmt::format("line {}: expected 'key: value', got '{}'", l.number, l.text.substr(0, 40)));
      }
      const std::string key = Unquote(Trim(l.text.substr(0, colon)));
      std::string rest = Trim(l.text.substr(colon + 1));
      if (!rest.empty() && rest[0] == '!') {  // a tag (!!opencv-matrix): the value follows it
        const auto sp = rest.find(' ');
        rest = sp == std::string::npos ? "" : Trim(rest.substr(sp));
      }
      const int number = l.number;
      ++i;
      YNode v;
      if (rest.empty()) {
        if (i < lines_.size() && (lines_[i].indent > indent || (lines_[i].indent == indent && IsDash(lines_[i])))) {
          v = Block(i, lines_[i].indent, depth + 1);
        } else {
          v.line = number;
        }
      } else {
        v = Inline(rest, number, depth);
      }
      for (const auto& [k, unused] : n.map) {
        if (k == key) throw InvalidInput(field_, fmt::format("line {}: key '{}' given twice", number, key.substr(0, 40)));
      }
      n.map.emplace_back(key, std::move(v));
    }
    if (i < lines_.size() && lines_[i].indent > indent) {
      throw InvalidInput(field_, fmt::format("line {}: unexpected indentation", lines_[i].number));
    }
    return n;
  }

  YNode Inline(const std::string& s, int line, int depth) {
    if (depth > kMaxYamlDepth) throw InvalidInput(field_, fmt::format("line {}: nested deeper than {}", line, kMaxYamlDepth));
    YNode n;
    n.line = line;
    if (s.empty()) return n;
    if (s[0] == '{') throw InvalidInput(field_, fmt::format("line {}: flow mappings {{ … }} are not read", line));
    if (s[0] != '[') {
      n.kind = YNode::kScalar;
      n.scalar = Unquote(s);
      return n;
    }
    if (s.back() != ']') throw InvalidInput(field_, fmt::format("line {}: text after ']'", line));
    n.kind = YNode::kSeq;
    const std::string body = s.substr(1, s.size() - 2);
    int d = 0;
    std::size_t start = 0;
    for (std::size_t k = 0; k <= body.size(); ++k) {
      const char c = k < body.size() ? body[k] : ',';
      if (c == '[') ++d;
      if (c == ']') --d;
      if (c == ',' && d == 0) {
        const std::string item = Trim(body.substr(start, k - start));
        start = k + 1;
        if (item.empty()) {
          if (k == body.size() && !n.seq.empty()) break;  // a trailing comma
          if (k == body.size() && Trim(body).empty()) break;  // []
          throw InvalidInput(field_, fmt::format("line {}: an empty item in [ … ]", line));
        }
        n.seq.push_back(Inline(item, line, depth + 1));
      }
    }
    return n;
  }

  std::string field_;
  std::vector<YLine> lines_;
};

YNode ParseYaml(std::string_view text, const std::string& field) { return YamlReader(text, field).Parse(); }

// An XML <opencv_storage> document as the YAML tree: elements with children are mappings, others
// scalars (their text).
YNode XmlToNode(const XmlDocument& doc, const XmlElement& e) {
  YNode n;
  n.line = e.line;
  if (e.children.empty()) {
    n.kind = YNode::kScalar;
    n.scalar = Unquote(Trim(e.text));
    return n;
  }
  n.kind = YNode::kMap;
  for (int c : e.children) n.map.emplace_back(doc.elements[c].name, XmlToNode(doc, doc.elements[c]));
  return n;
}

const YNode& Need(const YNode& map, std::string_view key, const std::string& where) {
  const YNode* n = map.kind == YNode::kMap ? map.Get(key) : nullptr;
  if (n == nullptr || n->kind == YNode::kNull) throw InvalidInput(where + ": " + std::string(key), "missing");
  return *n;
}

double ToNumber(const std::string& s, const std::string& where) {
  char* end = nullptr;
  const std::string t = Trim(s);
  const double v = std::strtod(t.c_str(), &end);
  if (t.empty() || end != t.c_str() + t.size() || !std::isfinite(v)) {
    throw InvalidInput(where, "'" + t.substr(0, 40) + "' is not a finite number");
  }
  return v;
}

double Number(const YNode& n, const std::string& where) {
  if (n.kind != YNode::kScalar) throw InvalidInput(where, "must be a number");
  return ToNumber(n.scalar, where);
}

int PixelsValue(double v, const std::string& where) {
  if (!(v >= 1 && v <= 1e6 && v == std::floor(v))) throw InvalidInput(where, "must be a whole number of pixels from 1 to 1000000");
  return static_cast<int>(v);
}
int Pixels(const YNode& n, const std::string& where) { return PixelsValue(Number(n, where), where); }

YNode Scalar(std::string text) {
  YNode n;
  n.kind = YNode::kScalar;
  n.scalar = std::move(text);
  return n;
}

// The numbers of a list (nested lists flattened in order) or of a scalar of numbers separated by
// white space or commas (OpenCV's XML <data>).
void Flatten(const YNode& n, const std::string& where, std::vector<double>* out) {
  if (out->size() > 1024) throw InvalidInput(where, "more than 1024 numbers");
  if (n.kind == YNode::kSeq) {
    for (const auto& c : n.seq) Flatten(c, where, out);
  } else if (n.kind == YNode::kScalar) {
    std::size_t p = 0;
    const std::string& s = n.scalar;
    while ((p = s.find_first_not_of(" \t\r\n,", p)) != std::string::npos) {
      const std::size_t e = std::min(s.find_first_of(" \t\r\n,", p), s.size());
      out->push_back(ToNumber(s.substr(p, e - p), where));
      p = e;
    }
  } else {
    throw InvalidInput(where, "must be a list of numbers");
  }
}

// A matrix: a {rows, cols, data} mapping (OpenCV, ROS) or a list, with `count` numbers.
std::vector<double> Matrix(const YNode& n, std::size_t count, const std::string& where) {
  std::vector<double> v;
  if (n.kind == YNode::kMap) {
    Flatten(Need(n, "data", where), where + ".data", &v);
    if (n.Get("rows") && n.Get("cols")) {
      const double r = Number(*n.Get("rows"), where + ".rows"), c = Number(*n.Get("cols"), where + ".cols");
      if (r * c != static_cast<double>(v.size())) {
        throw InvalidInput(where, fmt::format("rows x cols = {:g} x {:g} but data holds {} numbers", r, c, v.size()));
      }
    }
  } else {
    Flatten(n, where, &v);
  }
  if (count > 0 && v.size() != count) throw InvalidInput(where, fmt::format("must hold {} numbers, not {}", count, v.size()));
  return v;
}

Eigen::Matrix3d Rotation(const std::vector<double>& v, const std::string& where) {
  Eigen::Matrix3d r;
  for (int a = 0; a < 3; ++a) {
    for (int b = 0; b < 3; ++b) r(a, b) = v[3 * a + b];
  }
  if (!((r.transpose() * r - Eigen::Matrix3d::Identity()).norm() < 1e-6 && r.determinant() > 0)) {
    throw InvalidInput(where, "is not a rotation matrix (orthonormal, determinant +1)");
  }
  return r;
}

Eigen::Vector3d RotationVector(const Eigen::Matrix3d& r) {
  const Eigen::AngleAxisd aa(r);
  return aa.angle() * aa.axis();
}
Eigen::Matrix3d FromRotationVector(const Eigen::Vector3d& v) {
  return v.norm() > 0 ? Eigen::AngleAxisd(v.norm(), v.normalized()).toRotationMatrix() : Eigen::Matrix3d::Identity();
}

double UnitMm(LengthUnit u) { return u == LengthUnit::kMm ? 1.0 : u == LengthUnit::kCm ? 10.0 : 1000.0; }
std::string_view UnitName(LengthUnit u) {
  return u == LengthUnit::kMm ? "mm" : u == LengthUnit::kCm ? "cm" : u == LengthUnit::kM ? "m" : "unstated";
}

// ---- Cameras as the formats hold them ----

Camera PixelOpenCV(int w, int h, double pitch, const std::vector<double>& k, const std::vector<double>& d) {
  Camera c{CameraModelId::kOpenCV, {w, h, pitch}, std::vector<double>(OpenCV::kNumParams, 0.0)};
  c.params[OpenCV::kFx] = k[0];
  c.params[OpenCV::kFy] = k[4];
  c.params[OpenCV::kCx] = k[2];
  c.params[OpenCV::kCy] = k[5];
  for (std::size_t i = 0; i < d.size() && i < 8; ++i) c.params[OpenCV::kK1 + i] = d[i];
  return c;
}
Camera PixelKB(int w, int h, double pitch, const std::vector<double>& k, const std::vector<double>& d) {
  return Camera{CameraModelId::kKannalaBrandt, {w, h, pitch}, {k[0], k[4], k[2], k[5], d[0], d[1], d[2], d[3]}};
}

std::vector<double> CheckCameraMatrix(const std::vector<double>& k, const std::string& where) {
  if (k[1] != 0 || k[3] != 0 || k[6] != 0 || k[7] != 0 || k[8] != 1 || !(k[0] > 0 && k[4] > 0)) {
    throw InvalidInput(where, "must be [fx 0 cx; 0 fy cy; 0 0 1] with fx, fy > 0 (no skew)");
  }
  return k;
}

// OpenCV's distortion vector: 4, 5, 8, or 12/14 with zero thin-prism and tilt terms.
std::vector<double> CheckOpenCVDistortion(const std::vector<double>& d, const std::string& where) {
  const std::size_t n = d.size();
  if (n != 4 && n != 5 && n != 8 && n != 12 && n != 14) {
    throw InvalidInput(where, fmt::format("has {} entries; OpenCV has 4, 5, 8, 12 or 14", n));
  }
  for (std::size_t i = 8; i < n; ++i) {
    if (d[i] != 0) throw InvalidInput(where, "thin-prism s1-s4 and tilt tau_x, tau_y must be 0 (porthole's opencv model has k1-k6, p1, p2)");
  }
  return d;
}

struct Fitted {
  Camera cam;
  bool exact = true;
  camera::ConversionFit fit;
};

// `src` refit over the image into `start`'s model (opencv or kannala-brandt) with the parameters
// `free` adjusted.
template <typename M>
Fitted Refit(const Camera& src, Camera start, const std::vector<bool>& free, const std::string& field) {
  Fitted out{std::move(start), false, {}};
  camera::VisitModel(src.model, [&](auto model) {
    using S = decltype(model);
    const refit::ListProjector<S> sp{src.sensor};
    const auto rays = refit::GridRays(src.sensor, [&](const Eigen::Vector2d& uv) { return src.Unproject(uv); });
    const refit::ProjectedRays data = refit::ProjectRays(sp, src.params, rays);
    const refit::ListProjector<M> dst{src.sensor};
    out.fit = refit::Fit(dst, &out.cam.params, free, data.rays, data.px);
  });
  const std::string what = fmt::format("the refit of the {} camera to the {} model", src.model_name(), out.cam.model_name());
  camera::RequirePossibleResult(out.cam, out.fit.rms_px, field, what);
  if (!(out.fit.rms_px <= kMaxRefitRmsPx)) {
    throw InvalidInput(field, fmt::format("{} misses the camera by RMS {:.3g} px (max {:.3g} px) over the image, above the {:g} px "
                                          "a conversion may differ: the format cannot hold this camera",
                                          what, out.fit.rms_px, out.fit.max_px, kMaxRefitRmsPx));
  }
  return out;
}

// The camera as an opencv camera whose distortion the first `n_dist` coefficients hold (4: k1 k2 p1
// p2; 5: + k3; 8: + k4 k5 k6): exact when it already is, else refit over the image.
Fitted AsOpenCV(const Camera& c, int n_dist, const std::string& field) {
  Camera start;
  if (c.model == CameraModelId::kOpenCV) {
    start = c;
  } else if (c.model == CameraModelId::kBrown) {
    start = ConvertCalibration(WithoutSigma(c, ""), CameraModelId::kOpenCV, field).camera;  // the closed form
  } else if (c.model == CameraModelId::kKannalaBrandt) {
    start = Camera{CameraModelId::kOpenCV, c.sensor, std::vector<double>(OpenCV::kNumParams, 0.0)};
    std::copy(c.params.begin(), c.params.begin() + 4, start.params.begin());
  } else if (c.model == CameraModelId::kEquidistant) {
    const Camera kb = ConvertCalibration(WithoutSigma(c, ""), CameraModelId::kKannalaBrandt, field).camera;
    return AsOpenCV(kb, n_dist, field);
  } else {
    ConvertCalibration(WithoutSigma(c, ""), CameraModelId::kOpenCV, field);  // throws its line
  }
  for (int i = OpenCV::kK1 + n_dist; i < OpenCV::kNumParams; ++i) start.params[i] = 0;
  if (c.model == CameraModelId::kOpenCV && start.params == c.params) return {c, true, {}};
  std::vector<bool> free(OpenCV::kNumParams, false);
  for (int i = 0; i < OpenCV::kK1 + n_dist; ++i) free[i] = true;
  return Refit<OpenCV>(c, start, free, field);
}

// Kannala–Brandt (cv::fisheye, Kalibr's equi, ROS's equidistant): exact from kannala-brandt and
// equidistant; nullopt for other models.
std::optional<Camera> AsKB(const Camera& c, const std::string& field) {
  if (c.model == CameraModelId::kKannalaBrandt) return c;
  if (c.model == CameraModelId::kEquidistant) {
    return ConvertCalibration(WithoutSigma(c, ""), CameraModelId::kKannalaBrandt, field).camera;
  }
  return std::nullopt;
}

// The fewest of 4, 5, 8 OpenCV coefficients that hold an opencv camera exactly.
int OpenCVCount(const Camera& c) {
  const auto& p = c.params;
  if (p[OpenCV::kK4] != 0 || p[OpenCV::kK5] != 0 || p[OpenCV::kK6] != 0) return 8;
  return p[OpenCV::kK3] != 0 ? 5 : 4;
}

std::vector<double> KMatrix(const Camera& c) {
  const auto& p = c.params;
  return {p[0], 0, p[2], 0, p[1], p[3], 0, 0, 1};
}

std::string NumList(const std::vector<double>& v, std::string_view sep = ", ") {
  std::string s;
  for (double x : v) {
    if (!s.empty()) s.append(sep);
    s.append(Float(x));
  }
  return s;
}

void RequireNoPort(const RigFile& rig, RigFormat format, const std::string& field) {
  for (const auto& c : rig.cameras) {
    if (!c.port.empty()) {
      throw InvalidInput(field, fmt::format("camera {} is behind a port ({}): {} has no refraction (keep porthole's rig "
                                            "JSON, or calibrate in air for this format)",
                                            c.name, c.port, RigFormatName(format)));
    }
  }
}

void RequirePair(const RigFile& rig, RigFormat format, const std::string& field) {
  if (rig.cameras.size() != 2) {
    throw InvalidInput(field, fmt::format("{} holds a stereo pair; the rig has {} cameras (kalibr and json hold any number)",
                                          RigFormatName(format), rig.cameras.size()));
  }
}

// R, T of the pair: x2 = R·x1 + T (mm), from the cameras' cam_from_rig.
std::pair<Eigen::Matrix3d, Eigen::Vector3d> Relative(const RigFileCamera& a, const RigFileCamera& b) {
  const Eigen::Matrix3d r = b.rotation * a.rotation.transpose();
  return {r, b.translation_mm - r * a.translation_mm};
}

RigFileCamera Camera1(const std::string& name, const Camera& cam) {
  RigFileCamera c;
  c.name = name;
  c.calibration = WithoutSigma(cam, "");
  c.calibration.label = name;
  return c;
}

// ---- OpenCV stereo and VIAME npz: two opencv cameras, R, T ----

struct PairCameras {
  Fitted first, second;
};
PairCameras OpenCVPair(const RigFile& rig, RigFormat format, const std::string& field) {
  RequirePair(rig, format, field);
  RequireNoPort(rig, format, field);
  const auto one = [&](const RigFileCamera& c) {
    const std::string f = field + ": camera " + c.name;
    if (c.calibration.camera.model == CameraModelId::kOpenCV) {
      return AsOpenCV(c.calibration.camera, OpenCVCount(c.calibration.camera), f);
    }
    return AsOpenCV(c.calibration.camera, c.calibration.camera.model == CameraModelId::kBrown ? 5 : 8, f);
  };
  PairCameras p{one(rig.cameras[0]), one(rig.cameras[1])};
  const auto& s0 = p.first.cam.sensor;
  const auto& s1 = p.second.cam.sensor;
  if (format != RigFormat::kViameNpz && (s0.width_px != s1.width_px || s0.height_px != s1.height_px)) {
    throw InvalidInput(field, fmt::format("OpenCV's stereo file has one image size; the cameras' are {}x{} and {}x{}",
                                          s0.width_px, s0.height_px, s1.width_px, s1.height_px));
  }
  return p;
}

std::vector<double> Coefficients(const Camera& c, int n) {
  return std::vector<double>(c.params.begin() + OpenCV::kK1, c.params.begin() + OpenCV::kK1 + n);
}

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

// The unit of an unstated T: the file's T_unit, else the option, else refused.
double TUnitMm(const YNode* stated, const RigReadOptions& o, const std::string& where, RigFile* rig) {
  if (stated != nullptr) {
    const std::string u = Trim(stated->scalar);
    const LengthUnit unit = LengthUnitFromName(u, where + ": T_unit");
    if (o.length_unit != LengthUnit::kUnstated && o.length_unit != unit) {
      throw InvalidInput(where + ": T_unit", fmt::format("the file states {}, but {} was given", u, UnitName(o.length_unit)));
    }
    rig->length_unit_note = u + ", stated in the file";
    return UnitMm(unit);
  }
  if (o.length_unit == LengthUnit::kUnstated) {
    throw InvalidInput(where + ": T", "the file does not state T's unit (the calibration target's): give the length unit "
                                      "(choices: mm, cm, m)");
  }
  rig->length_unit_note = std::string(UnitName(o.length_unit)) + ", given";
  return UnitMm(o.length_unit);
}

RigFile PairRig(const Camera& c1, const Camera& c2, const Eigen::Matrix3d& r, const Eigen::Vector3d& t_mm,
                const std::string& n1, const std::string& n2) {
  RigFile rig;
  rig.cameras.push_back(Camera1(n1, c1));
  rig.cameras.push_back(Camera1(n2, c2));
  rig.cameras[1].rotation = r;
  rig.cameras[1].translation_mm = t_mm;
  return rig;
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

// ---- .npy and .npz ----

std::string Le16(unsigned v) { return {static_cast<char>(v & 0xff), static_cast<char>((v >> 8) & 0xff)}; }

RigFile ReadViameNpz(const std::string& bytes, const RigReadOptions& o, const std::string& field) {
  const auto members = ReadZip(bytes, field);
  const auto get = [&](const std::string& key) -> NpyArray {
    for (const auto& [name, data] : members) {
      if (name == key + ".npy") return ParseNpy(data, field + ": " + key);
    }
    throw InvalidInput(field + ": " + key, "missing (VIAME's npz holds cameraMatrixL, distCoeffsL, cameraMatrixR, distCoeffsR, R, T)");
  };
  const auto numbers = [&](const std::string& key, std::size_t count) {
    NpyArray a = get(key);
    if (a.is_text) throw InvalidInput(field + ": " + key, "must be numbers");
    if (count > 0 && a.data.size() != count) {
      throw InvalidInput(field + ": " + key, fmt::format("must hold {} numbers, not {}", count, a.data.size()));
    }
    return a.data;
  };
  const auto km = [&](const std::string& key) { return CheckCameraMatrix(numbers(key, 9), field + ": " + key); };
  const auto kl = km("cameraMatrixL"), kr = km("cameraMatrixR");
  const auto dl = CheckOpenCVDistortion(numbers("distCoeffsL", 0), field + ": distCoeffsL");
  const auto dr = CheckOpenCVDistortion(numbers("distCoeffsR", 0), field + ": distCoeffsR");
  const Eigen::Matrix3d r = Rotation(numbers("R", 9), field + ": R");
  const auto t = numbers("T", 3);
  // The image size: VIAME's npz has none (porthole writes imageSizeL/R), else the option.
  const auto size = [&](const std::string& key) -> std::pair<int, int> {
    for (const auto& [name, unused] : members) {
      if (name == key + ".npy") {
        const auto v = numbers(key, 2);
        return {PixelsValue(v[0], field + ": " + key), PixelsValue(v[1], field + ": " + key)};
      }
    }
    if (!o.image_size) {
      throw InvalidInput(field + ": " + key, "missing: VIAME's npz does not hold the image size: give it (width x height, px)");
    }
    return *o.image_size;
  };
  auto [wl, hl] = size("imageSizeL");
  auto [wr, hr] = size("imageSizeR");
  std::optional<YNode> unit;
  for (const auto& [name, data] : members) {
    if (name == "T_unit.npy") {
      const NpyArray a = ParseNpy(data, field + ": T_unit");
      if (!a.is_text) throw InvalidInput(field + ": T_unit", "must be text (mm, cm or m)");
      unit = Scalar(a.text);
    }
  }
  RigFile tmp;
  const double mm = TUnitMm(unit ? &*unit : nullptr, o, field, &tmp);
  RigFile rig = PairRig(PixelOpenCV(wl, hl, o.pixel_pitch_mm, kl, dl), PixelOpenCV(wr, hr, o.pixel_pitch_mm, kr, dr), r,
                        Eigen::Vector3d(t[0], t[1], t[2]) * mm, "left", "right");
  rig.length_unit_note = tmp.length_unit_note;
  rig.format = RigFormat::kViameNpz;
  return rig;
}

std::string WriteViameNpz(const RigFile& rig, const std::string& field, std::vector<RigWriteCamera>* info) {
  const PairCameras p = OpenCVPair(rig, RigFormat::kViameNpz, field);
  const auto [r, t] = Relative(rig.cameras[0], rig.cameras[1]);
  const int n1 = std::max(OpenCVCount(p.first.cam), 5), n2 = std::max(OpenCVCount(p.second.cam), 5);  // as cv2.stereoCalibrate
  const Eigen::Matrix3d rt = r.transpose();
  const auto arr = [](std::vector<int> shape, std::vector<double> data) {
    NpyArray a;
    a.shape = std::move(shape);
    a.data = std::move(data);
    return NpyBytes(a);
  };
  NpyArray unit;
  unit.is_text = true;
  unit.text = "mm";
  const auto& s1 = p.first.cam.sensor;
  const auto& s2 = p.second.cam.sensor;
  std::vector<std::pair<std::string, std::string>> m = {
      {"cameraMatrixL.npy", arr({3, 3}, KMatrix(p.first.cam))},
      {"distCoeffsL.npy", arr({1, n1}, Coefficients(p.first.cam, n1))},
      {"cameraMatrixR.npy", arr({3, 3}, KMatrix(p.second.cam))},
      {"distCoeffsR.npy", arr({1, n2}, Coefficients(p.second.cam, n2))},
      {"R.npy", arr({3, 3}, std::vector<double>(rt.data(), rt.data() + 9))},
      {"T.npy", arr({3, 1}, {t(0), t(1), t(2)})},
      {"imageSizeL.npy", arr({2}, {double(s1.width_px), double(s1.height_px)})},
      {"imageSizeR.npy", arr({2}, {double(s2.width_px), double(s2.height_px)})},
      {"T_unit.npy", NpyBytes(unit)}};
  info->push_back({rig.cameras[0].name, fmt::format("{} coefficients", n1), p.first.exact, p.first.fit});
  info->push_back({rig.cameras[1].name, fmt::format("{} coefficients", n2), p.second.exact, p.second.fit});
  return ZipStored(m, field);
}

// ---- ROS camera_info ----

// cv::stereoRectify's rotations (calib3d/src/calibration.cpp, cvStereoRectify): half the relative
// rotation to each camera, then the rotation taking the baseline onto the x (or y) axis.
std::pair<Eigen::Matrix3d, Eigen::Matrix3d> RectifyRotations(const Eigen::Matrix3d& r, const Eigen::Vector3d& t) {
  const Eigen::Matrix3d r_r = FromRotationVector(-0.5 * RotationVector(r));
  const Eigen::Vector3d tt = r_r * t;
  const int idx = std::abs(tt(0)) > std::abs(tt(1)) ? 0 : 1;
  const double c = tt(idx), nt = tt.norm();
  Eigen::Vector3d uu = Eigen::Vector3d::Zero();
  uu(idx) = c > 0 ? 1 : -1;
  Eigen::Vector3d ww = tt.cross(uu);
  const double nw = ww.norm();
  if (nw > 0) ww *= std::acos(std::abs(c) / nt) / nw;
  const Eigen::Matrix3d wr = FromRotationVector(ww);
  return {wr * r_r.transpose(), wr * r_r};
}

struct RosCamera {
  Fitted fit;
  std::string model;  // plumb_bob, rational_polynomial, equidistant
  std::vector<double> d;
};
RosCamera ToRos(const Camera& c, const std::string& field) {
  if (const auto kb = AsKB(c, field)) return {{*kb, true, {}}, "equidistant", Coefficients(*kb, 4)};
  const int n = c.model == CameraModelId::kOpenCV && OpenCVCount(c) == 8 ? 8 : 5;
  if (c.model != CameraModelId::kOpenCV && c.model != CameraModelId::kBrown) {
    ConvertCalibration(WithoutSigma(c, ""), CameraModelId::kOpenCV, field);  // throws its line
  }
  RosCamera r{AsOpenCV(c, n, field), n == 8 ? "rational_polynomial" : "plumb_bob", {}};
  r.d = Coefficients(r.fit.cam, n);
  return r;
}

std::string RosText(const std::string& name, const Camera& cam, const std::string& model, const std::vector<double>& d,
                    const Eigen::Matrix3d& rect, const std::vector<double>& p) {
  Eigen::Matrix3d rt = rect.transpose();
  const auto m = [](std::string_view key, int rows, int cols, const std::vector<double>& v) {
    return fmt::format("{}:\n  rows: {}\n  cols: {}\n  data: [{}]\n", key, rows, cols, NumList(v));
  };
  std::string clean = name.substr(0, 200);
  for (char& ch : clean) {
    if (static_cast<unsigned char>(ch) < 0x20 || ch == 0x7f) ch = '_';  // one line
  }
  std::string quoted = clean;
  if (clean.find_first_of(":#'\"[]{},&*!|>%@`\\ -?") != std::string::npos || clean.empty()) {
    quoted = "\"";
    for (char ch : clean) {
      if (ch == '"' || ch == '\\') quoted += '\\';
      quoted += ch;
    }
    quoted += "\"";
  }
  return fmt::format("image_width: {}\nimage_height: {}\ncamera_name: {}\n{}distortion_model: {}\n{}{}{}", cam.sensor.width_px,
                     cam.sensor.height_px, quoted, m("camera_matrix", 3, 3, KMatrix(cam)), model,
                     m("distortion_coefficients", 1, static_cast<int>(d.size()), d),
                     m("rectification_matrix", 3, 3, std::vector<double>(rt.data(), rt.data() + 9)),
                     m("projection_matrix", 3, 4, p));
}

std::vector<std::pair<std::string, std::string>> WriteRos(const RigFile& rig, const std::string& field,
                                                          std::vector<RigWriteCamera>* info) {
  RequirePair(rig, RigFormat::kRosCameraInfo, field);
  RequireNoPort(rig, RigFormat::kRosCameraInfo, field);
  if (rig.cameras[0].name == rig.cameras[1].name) {
    throw InvalidInput(field, "both cameras are called " + rig.cameras[0].name + ": ROS's files are named after them");
  }
  const RosCamera a = ToRos(rig.cameras[0].calibration.camera, field + ": camera " + rig.cameras[0].name);
  const RosCamera b = ToRos(rig.cameras[1].calibration.camera, field + ": camera " + rig.cameras[1].name);
  const auto [r, t_mm] = Relative(rig.cameras[0], rig.cameras[1]);
  const Eigen::Vector3d t = t_mm / 1000;  // metres (REP 103)
  const auto [r1, r2] = RectifyRotations(r, t);
  const auto& pa = a.fit.cam.params;
  const auto& pb = b.fit.cam.params;
  const double f = 0.25 * (pa[0] + pa[1] + pb[0] + pb[1]);
  const double cx = 0.5 * (pa[2] + pb[2]), cy = 0.5 * (pa[3] + pb[3]);
  const Eigen::Vector3d t2 = r2 * t;  // camera 1's centre seen from camera 2, rectified frame
  const std::vector<double> p1{f, 0, cx, 0, 0, f, cy, 0, 0, 0, 1, 0};
  const std::vector<double> p2{f, 0, cx, f * t2(0), 0, f, cy, f * t2(1), 0, 0, 1, 0};
  // File names from the camera names, kept to [A-Za-z0-9._-] (a name is never a path).
  const auto file_name = [](const std::string& name) {
    std::string f = name.substr(0, 100);
    for (char& ch : f) {
      if (!std::isalnum(static_cast<unsigned char>(ch)) && ch != '.' && ch != '_' && ch != '-') ch = '_';
    }
    if (f.empty() || f[0] == '.') f = "camera_" + f;
    return f + ".yaml";
  };
  if (file_name(rig.cameras[0].name) == file_name(rig.cameras[1].name)) {
    throw InvalidInput(field, "the cameras' names give one file name (" + file_name(rig.cameras[0].name) + "): rename them");
  }
  std::vector<std::pair<std::string, std::string>> files;
  files.emplace_back(file_name(rig.cameras[0].name), RosText(rig.cameras[0].name, a.fit.cam, a.model, a.d, r1, p1));
  files.emplace_back(file_name(rig.cameras[1].name), RosText(rig.cameras[1].name, b.fit.cam, b.model, b.d, r2, p2));
  info->push_back({rig.cameras[0].name, a.model, a.fit.exact, a.fit.fit});
  info->push_back({rig.cameras[1].name, b.model, b.fit.exact, b.fit.fit});
  return files;
}

struct RosRead {
  std::string name;
  Camera cam;
  Eigen::Matrix3d rect;
  std::vector<double> p;
};
RosRead ReadRosOne(const std::string& text, double pitch, const std::string& field) {
  const YNode root = ParseYaml(text, field);
  if (root.kind != YNode::kMap) throw InvalidInput(field, "not a ROS camera_info YAML");
  RosRead r;
  const YNode* name = root.Get("camera_name");
  r.name = name != nullptr && name->kind == YNode::kScalar ? name->scalar : "";
  const int w = Pixels(Need(root, "image_width", field), field + ": image_width");
  const int h = Pixels(Need(root, "image_height", field), field + ": image_height");
  const auto k = CheckCameraMatrix(Matrix(Need(root, "camera_matrix", field), 9, field + ": camera_matrix"),
                                   field + ": camera_matrix");
  const auto d = Matrix(Need(root, "distortion_coefficients", field), 0, field + ": distortion_coefficients");
  const YNode* dm = root.Get("distortion_model");
  const std::string model = dm != nullptr && dm->kind == YNode::kScalar ? dm->scalar : "plumb_bob";
  if (model == "equidistant" || model == "fisheye") {
    if (d.size() != 4) throw InvalidInput(field + ": distortion_coefficients", fmt::format("{} holds 4 (k1-k4), not {}", model, d.size()));
    r.cam = PixelKB(w, h, pitch, k, d);
  } else if (model == "plumb_bob" || model == "rational_polynomial") {
    if (d.size() > 8 && std::any_of(d.begin() + 8, d.end(), [](double x) { return x != 0; })) {
      throw InvalidInput(field + ": distortion_coefficients", "more than 8 non-zero coefficients (porthole's opencv model has k1-k6, p1, p2)");
    }
    r.cam = PixelOpenCV(w, h, pitch, k, d);
  } else {
    throw InvalidInput(field + ": distortion_model",
                       "'" + model.substr(0, 40) + "' is not read (plumb_bob, rational_polynomial, equidistant)");
  }
  r.rect = Rotation(Matrix(Need(root, "rectification_matrix", field), 9, field + ": rectification_matrix"),
                    field + ": rectification_matrix");
  r.p = Matrix(Need(root, "projection_matrix", field), 12, field + ": projection_matrix");
  if (!(r.p[0] > 0 && r.p[5] > 0)) throw InvalidInput(field + ": projection_matrix", "fx' and fy' must be > 0");
  return r;
}

RigFile ReadRos(const std::vector<std::string>& contents, const std::vector<std::string>& names, const RigReadOptions& o,
                const std::string& field) {
  if (contents.size() != 2) {
    throw InvalidInput(field, fmt::format("ROS camera_info: give one file per camera of a stereo pair (2), not {}", contents.size()));
  }
  std::vector<RosRead> cams;
  for (std::size_t i = 0; i < 2; ++i) cams.push_back(ReadRosOne(contents[i], o.pixel_pitch_mm, field + " '" + names[i] + "'"));
  const auto& p2 = cams[1].p;
  if (std::abs(cams[0].p[3]) > 0 || std::abs(cams[0].p[7]) > 0) {
    throw InvalidInput(field + " '" + names[0] + "': projection_matrix",
                       "the first camera's P has a translation: give the files in the pair's order (left, right)");
  }
  if (p2[3] == 0 && p2[7] == 0) {
    throw InvalidInput(field + " '" + names[1] + "': projection_matrix",
                       "Tx = Ty = 0: not a stereo pair's second camera (camera_info holds the pose only through the stereo "
                       "rectification)");
  }
  const Eigen::Vector3d t_rect(p2[3] / p2[0], p2[7] / p2[5], 0);  // metres
  const Eigen::Matrix3d r = cams[1].rect.transpose() * cams[0].rect;
  const Eigen::Vector3d t = cams[1].rect.transpose() * t_rect * 1000;
  RigFile rig = PairRig(cams[0].cam, cams[1].cam, r, t,
                        cams[0].name.empty() ? std::filesystem::path(names[0]).stem().string() : cams[0].name,
                        cams[1].name.empty() ? std::filesystem::path(names[1]).stem().string() : cams[1].name);
  rig.format = RigFormat::kRosCameraInfo;
  rig.length_unit_note = "metres (ROS REP 103)";
  return rig;
}

// ---- Kalibr camchain ----

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

std::string ReadWhole(const std::string& path, const std::string& field) {
  return ReadInputFile(path, field, kMaxCalibrationFileBytes);
}


constexpr std::array<std::pair<RigFormat, std::string_view>, 6> kRigFormats{{
    {RigFormat::kJson, "json"},
    {RigFormat::kOpenCVStereoYaml, "opencv-stereo"},
    {RigFormat::kOpenCVStereoXml, "opencv-stereo-xml"},
    {RigFormat::kViameNpz, "viame-npz"},
    {RigFormat::kRosCameraInfo, "ros-camera-info"},
    {RigFormat::kKalibr, "kalibr"},
}};

}  // namespace

std::string_view RigFormatName(RigFormat f) {
  for (const auto& [id, name] : kRigFormats) {
    if (id == f) return name;
  }
  return "?";
}

std::string RigFormatNames() {
  std::string s;
  for (const auto& [id, name] : kRigFormats) s += (s.empty() ? "" : ", ") + std::string(name);
  return s;
}

RigFormat RigFormatFromName(std::string_view name, const std::string& field) {
  for (const auto& [id, n] : kRigFormats) {
    if (n == name) return id;
  }
  throw InvalidInput(field, fmt::format("unknown rig format '{}' (known: {})", std::string(name).substr(0, 40), RigFormatNames()));
}

LengthUnit LengthUnitFromName(std::string_view name, const std::string& field) {
  if (name == "mm") return LengthUnit::kMm;
  if (name == "cm") return LengthUnit::kCm;
  if (name == "m") return LengthUnit::kM;
  throw InvalidInput(field, fmt::format("unknown length unit '{}' (choices: mm, cm, m)", std::string(name).substr(0, 20)));
}

bool RigWriteResult::exact() const {
  return std::all_of(cameras.begin(), cameras.end(), [](const RigWriteCamera& c) { return c.exact; });
}
double RigWriteResult::worst_rms_px() const {
  double w = 0;
  for (const auto& c : cameras) {
    if (!c.exact) w = std::max(w, c.fit.rms_px);
  }
  return w;
}

RigFile RigFileFromJson(const nlohmann::json& j, const std::string& field) {
  if (!j.is_object() || !j.contains("rig")) {
    if (j.is_object() && j.contains("camera")) {
      throw InvalidInput(field, "a single camera's calibration, not a rig (a rig JSON has a \"rig\" object)");
    }
    throw InvalidInput(field, "not a rig calibration: no \"rig\" object");
  }
  const Json& r = j["rig"];
  const std::string rf = field + ".rig";
  if (!r.is_object() || !r.contains("cameras") || !r["cameras"].is_array() || r["cameras"].empty()) {
    throw InvalidInput(rf + ".cameras", "must be a non-empty list");
  }
  RigFile rig;
  rig.format = RigFormat::kJson;
  rig.pitch_known = true;
  rig.length_unit_note = "mm (porthole)";
  for (std::size_t k = 0; k < r["cameras"].size(); ++k) {
    const Json& cj = r["cameras"][k];
    const std::string cf = fmt::format("{}.cameras[{}]", rf, k);
    RigFileCamera c;
    c.name = cj.contains("name") && cj["name"].is_string() ? cj["name"].get<std::string>() : fmt::format("camera{}", k);
    c.calibration = calib::CalibrationFromJson(cj, cf);
    c.calibration.label = c.name;
    if (!cj.contains("cam_from_rig") || !cj["cam_from_rig"].is_object()) throw InvalidInput(cf + ".cam_from_rig", "missing");
    const Json& p = cj["cam_from_rig"];
    Eigen::Vector3d rv, tv;
    for (auto [key, out] : {std::pair<const char*, Eigen::Vector3d*>{"rotation_rad", &rv}, {"translation_mm", &tv}}) {
      const std::string where = cf + ".cam_from_rig." + key;
      if (!p.contains(key) || !p[key].is_array() || p[key].size() != 3) throw InvalidInput(where, "must be a list of 3 numbers");
      for (int i = 0; i < 3; ++i) {
        if (!p[key][i].is_number() || !std::isfinite(p[key][i].get<double>())) throw InvalidInput(where, "must be 3 finite numbers");
        (*out)(i) = p[key][i].get<double>();
      }
    }
    c.rotation = FromRotationVector(rv);
    c.translation_mm = tv;
    if (cj.contains("port") && !cj["port"].is_null()) {
      c.port = cj["port"].is_object() && cj["port"].contains("name") && cj["port"]["name"].is_string()
                   ? cj["port"]["name"].get<std::string>()
                   : "a port";
    }
    rig.cameras.push_back(std::move(c));
  }
  return rig;
}

RigFile RigFileFromResult(const calib::RigResult& r) {
  RigFile rig;
  rig.pitch_known = true;
  rig.length_unit_note = "mm (porthole)";
  for (const auto& c : r.cameras) {
    RigFileCamera rc;
    rc.name = c.name;
    rc.calibration.label = c.name;
    rc.calibration.camera = c.calibration.camera;
    rc.calibration.free = c.calibration.free;
    rc.calibration.covariance = c.calibration.covariance;
    rc.calibration.has_covariance = true;
    rc.calibration.sigma0_px = c.calibration.sigma0_px;
    rc.rotation = FromRotationVector(c.rotation_rad);
    rc.translation_mm = c.translation_mm;
    if (c.has_port) rc.port = c.estimated_port.name.empty() ? "a port" : c.estimated_port.name;
    rig.cameras.push_back(std::move(rc));
  }
  return rig;
}

nlohmann::ordered_json RigFileToJson(const RigFile& rig) {
  nlohmann::ordered_json cameras = nlohmann::ordered_json::array();
  for (const auto& c : rig.cameras) {
    if (!c.port.empty()) {
      throw InvalidInput("rig", "camera " + c.name + " is behind a port: a rig file read from another format has none");
    }
    const WriteResult w = WriteCalibration(c.calibration, Format::kJson, "rig: camera " + c.name);
    const auto cal = nlohmann::ordered_json::parse(w.content);
    const Eigen::Vector3d rv = RotationVector(c.rotation);
    nlohmann::ordered_json out = {{"name", c.name},
                                  {"cam_from_rig",
                                   {{"rotation_rad", {rv(0), rv(1), rv(2)}},
                                    {"translation_mm", {c.translation_mm(0), c.translation_mm(1), c.translation_mm(2)}}}}};
    for (const auto& [k, v] : cal.items()) out[k] = v;
    cameras.push_back(out);
  }
  return {{"rig",
           {{"frame", "camera 0's camera frame (X right, Y down, Z forward, mm); cam_from_rig maps it into each camera: "
                      "x_cam = R(rotation_rad) x_rig + translation_mm"},
            {"source", std::string(RigFormatName(rig.format))},
            {"length_unit", rig.length_unit_note},
            {"n_cameras", rig.cameras.size()},
            {"covariance_note", "none: a " + std::string(RigFormatName(rig.format)) + " rig file holds no covariance"},
            {"cameras", cameras}}}};
}

std::optional<RigFormat> DetectRigFormat(const std::string& path, const std::string& content) {
  const std::string ext = Lower(std::filesystem::path(path).extension().string());
  if (ext == ".npz" || content.rfind("PK\x03\x04", 0) == 0) return RigFormat::kViameNpz;
  const auto start = content.find_first_not_of(" \t\r\n");
  if (start == std::string::npos) return std::nullopt;
  if (content[start] == '{') {  // a rig JSON has a top-level "rig" object (ParseRigFiles checks it)
    for (std::size_t p = content.find("\"rig\""); p != std::string::npos; p = content.find("\"rig\"", p + 1)) {
      const auto colon = content.find_first_not_of(" \t\r\n", p + 5);
      if (colon != std::string::npos && content[colon] == ':') return RigFormat::kJson;
    }
    return std::nullopt;
  }
  const auto has_key = [&](std::string_view key) {
    for (std::size_t p = content.find(key); p != std::string::npos; p = content.find(key, p + 1)) {
      const bool line_start = p == 0 || content[p - 1] == '\n';
      const bool xml_tag = p > 0 && content[p - 1] == '<';
      const std::size_t e = p + key.size();
      if ((line_start && e < content.size() && content[e] == ':') || (xml_tag && e < content.size() && (content[e] == '>' || content[e] == ' '))) {
        return true;
      }
    }
    return false;
  };
  if (content[start] == '<') {
    if (has_key("K1") && has_key("T")) return RigFormat::kOpenCVStereoXml;
    return std::nullopt;
  }
  if (has_key("K1") && has_key("K2") && has_key("T")) return RigFormat::kOpenCVStereoYaml;
  if (has_key("cam0") && content.find("intrinsics") != std::string::npos) return RigFormat::kKalibr;
  if (has_key("camera_name") && has_key("projection_matrix")) return RigFormat::kRosCameraInfo;
  return std::nullopt;
}

RigFile ParseRigFiles(const std::vector<std::string>& contents, const std::vector<std::string>& names,
                      const RigReadOptions& options, const std::string& field) {
  if (contents.empty()) throw InvalidInput(field, "no rig file given");
  if (!(options.pixel_pitch_mm > 0)) throw InvalidInput("pixel_pitch_mm", "must be > 0");
  std::optional<RigFormat> format = options.format;
  if (!format) {
    format = DetectRigFormat(names[0], contents[0]);
    if (!format) {
      throw InvalidInput(field, fmt::format("'{}' is not a rig file ({}; a single camera's calibration is not a rig)",
                                            names[0], RigFormatNames()));
    }
  }
  const std::string f = contents.size() == 1 || *format != RigFormat::kRosCameraInfo ? field + " '" + names[0] + "'" : field;
  if (*format != RigFormat::kRosCameraInfo && contents.size() != 1) {
    throw InvalidInput(field, fmt::format("{} is one file; {} were given (only ros-camera-info takes one per camera)",
                                          RigFormatName(*format), contents.size()));
  }
  RigFile rig;
  switch (*format) {
    case RigFormat::kJson:
      rig = RigFileFromJson(ParseJsonText(contents[0], f, names[0]), f);
      break;
    case RigFormat::kOpenCVStereoYaml:
    case RigFormat::kOpenCVStereoXml:
      rig = ReadOpenCVStereo(contents[0], *format == RigFormat::kOpenCVStereoXml, options, f);
      break;
    case RigFormat::kViameNpz:
      rig = ReadViameNpz(contents[0], options, f);
      break;
    case RigFormat::kRosCameraInfo:
      rig = ReadRos(contents, names, options, field);
      break;
    case RigFormat::kKalibr:
      rig = ReadKalibr(contents[0], options, f);
      break;
  }
  for (auto& c : rig.cameras) {
    try {
      camera::ValidateCalibration(c.calibration.camera, "camera " + c.name);
    } catch (const InvalidInput& e) {
      throw InvalidInput(f, e.what());
    }
  }
  return rig;
}

RigFile ReadRigFiles(const std::vector<std::string>& paths, const RigReadOptions& options, const std::string& field) {
  std::vector<std::string> contents;
  for (const auto& p : paths) contents.push_back(ReadWhole(p, field));
  return ParseRigFiles(contents, paths, options, field);
}

RigWriteResult WriteRigFile(const RigFile& rig, RigFormat format, const std::string& field) {
  RigWriteResult out;
  switch (format) {
    case RigFormat::kJson:
      out.files.emplace_back("", RigFileToJson(rig).dump(1) + "\n");
      for (const auto& c : rig.cameras) out.cameras.push_back({c.name, std::string(c.calibration.camera.model_name()), true, {}});
      break;
    case RigFormat::kOpenCVStereoYaml:
    case RigFormat::kOpenCVStereoXml:
      out.files.emplace_back("", WriteOpenCVStereo(rig, format == RigFormat::kOpenCVStereoXml, field, &out.cameras));
      break;
    case RigFormat::kViameNpz:
      out.files.emplace_back("", WriteViameNpz(rig, field, &out.cameras));
      break;
    case RigFormat::kRosCameraInfo:
      out.files = WriteRos(rig, field, &out.cameras);
      break;
    case RigFormat::kKalibr:
      out.files.emplace_back("", WriteKalibr(rig, field, &out.cameras));
      break;
  }
  return out;
}

RigFormat RigOutputFormat(const std::string& path, const std::optional<std::string>& to, const std::string& field) {
  if (to) return RigFormatFromName(*to, "to");
  const std::string ext = Lower(std::filesystem::path(path).extension().string());
  if (ext == ".json") return RigFormat::kJson;
  if (ext == ".npz") return RigFormat::kViameNpz;
  if (ext == ".xml") return RigFormat::kOpenCVStereoXml;
  if (std::filesystem::is_directory(path)) return RigFormat::kRosCameraInfo;
  if (ext == ".yml" || ext == ".yaml") {
    throw InvalidInput(field, fmt::format("'{}': a rig in .yaml could be opencv-stereo or kalibr (or ros-camera-info, one file a "
                                          "camera into a directory): give `to`",
                                          path));
  }
  throw InvalidInput(field, fmt::format("'{}': no rig format for this name; give `to` ({})", path, RigFormatNames()));
}

std::vector<calib::CalibrationRecord> ReadRigCalibrations(const std::vector<std::string>& paths,
                                                          const RigReadOptions& options, const std::string& field) {
  RigFile rig = ReadRigFiles(paths, options, field);
  std::vector<calib::CalibrationRecord> out;
  for (auto& c : rig.cameras) out.push_back(std::move(c.calibration));
  return out;
}

// ---- .npy (numpy's format description, numpy/lib/format.py: version 1.0 header) ----

std::string NpyBytes(const NpyArray& a) {
  std::string shape = "(";
  for (std::size_t i = 0; i < a.shape.size(); ++i) shape += fmt::format("{}, ", a.shape[i]);
  if (a.shape.size() > 1) shape.resize(shape.size() - 2);
  if (a.shape.size() == 1) shape.resize(shape.size() - 1);
  shape += ")";
  std::string data;
  std::string descr = "<f8";
  if (a.is_text) {
    descr = fmt::format("<U{}", std::max<std::size_t>(a.text.size(), 1));
    for (unsigned char ch : a.text) data += std::string{static_cast<char>(ch), 0, 0, 0};  // ASCII as UTF-32LE
    if (a.text.empty()) data = std::string(4, '\0');
    shape = "()";
  } else {
    data.resize(a.data.size() * 8);
    std::memcpy(data.data(), a.data.data(), data.size());
  }
  std::string header = fmt::format("{{'descr': '{}', 'fortran_order': False, 'shape': {}, }}", descr, shape);
  while ((10 + header.size() + 1) % 64 != 0) header += ' ';
  header += '\n';
  return std::string("\x93NUMPY\x01\x00", 8) + Le16(static_cast<unsigned>(header.size())) + header + data;
}

NpyArray ParseNpy(std::string_view b, const std::string& field) {
  if (b.size() < 10 || b.substr(0, 6) != std::string_view("\x93NUMPY", 6)) throw InvalidInput(field, "not a .npy array");
  const int major = static_cast<unsigned char>(b[6]);
  std::size_t hlen = 0, at = 0;
  if (major == 1) {
    hlen = static_cast<unsigned char>(b[8]) | (static_cast<unsigned char>(b[9]) << 8);
    at = 10;
  } else if (major == 2 || major == 3) {
    if (b.size() < 12) throw InvalidInput(field, "a truncated .npy header");
    for (int i = 3; i >= 0; --i) hlen = (hlen << 8) | static_cast<unsigned char>(b[8 + i]);
    at = 12;
  } else {
    throw InvalidInput(field, fmt::format(".npy version {} is not read (1, 2, 3)", major));
  }
  if (hlen > 4096 || at + hlen > b.size()) throw InvalidInput(field, "a truncated .npy header");
  const Json h = ParsePythonLiteral(b.substr(at, hlen), field);
  if (!h.is_object() || !h.contains("descr") || !h["descr"].is_string() || !h.contains("shape") || !h["shape"].is_array()) {
    throw InvalidInput(field, "a .npy header without descr and shape");
  }
  NpyArray a;
  std::size_t count = 1;
  if (h["shape"].size() > 8) throw InvalidInput(field, "a .npy shape of more than 8 dimensions");
  for (const auto& s : h["shape"]) {
    if (!s.is_number_integer() || s.get<long long>() < 0 || s.get<long long>() > 4096) throw InvalidInput(field, "a bad .npy shape");
    a.shape.push_back(s.get<int>());
    count *= static_cast<std::size_t>(s.get<int>());
    if (count > 4096) throw InvalidInput(field, "more than 4096 values");
  }
  const bool fortran = h.contains("fortran_order") && h["fortran_order"].is_boolean() && h["fortran_order"].get<bool>();
  const std::string descr = h["descr"].get<std::string>();
  const std::string_view data = b.substr(at + hlen);
  if (descr.size() > 2 && descr[1] == 'U' && (descr[0] == '<' || descr[0] == '|')) {
    const std::string digits = descr.substr(2);
    if (digits.empty() || digits.size() > 3 || digits.find_first_not_of("0123456789") != std::string::npos) {
      throw InvalidInput(field, "a bad text dtype '" + descr.substr(0, 20) + "'");
    }
    const std::size_t n = std::stoul(digits);
    if (count != 1 || n > 64 || data.size() < 4 * n) throw InvalidInput(field, "a text array must be one string of at most 64 characters");
    a.is_text = true;
    for (std::size_t i = 0; i < n; ++i) {
      const unsigned char ch = static_cast<unsigned char>(data[4 * i]);
      if (ch == 0) break;
      if (ch > 127 || data[4 * i + 1] || data[4 * i + 2] || data[4 * i + 3]) throw InvalidInput(field, "not ASCII text");
      a.text += static_cast<char>(ch);
    }
    return a;
  }
  const bool f8 = descr == "<f8", f4 = descr == "<f4";
  if (!f8 && !f4) throw InvalidInput(field, fmt::format("dtype '{}' is not read (float64 '<f8' or float32 '<f4')", descr.substr(0, 20)));
  const std::size_t item = f8 ? 8 : 4;
  if (data.size() != count * item) throw InvalidInput(field, fmt::format("holds {} bytes, not the {} its shape needs", data.size(), count * item));
  std::vector<double> v(count);
  for (std::size_t i = 0; i < count; ++i) {
    if (f8) {
      std::memcpy(&v[i], data.data() + 8 * i, 8);
    } else {
      float x;
      std::memcpy(&x, data.data() + 4 * i, 4);
      v[i] = x;
    }
    if (!std::isfinite(v[i])) throw InvalidInput(field, "holds a value that is not finite");
  }
  if (fortran && a.shape.size() == 2) {  // column-major → row-major
    const int rows = a.shape[0], cols = a.shape[1];
    std::vector<double> c(count);
    for (int r = 0; r < rows; ++r) {
      for (int q = 0; q < cols; ++q) c[r * cols + q] = v[q * rows + r];
    }
    v = std::move(c);
  } else if (fortran && a.shape.size() > 2) {
    throw InvalidInput(field, "a Fortran-ordered array of more than 2 dimensions");
  }
  a.data = std::move(v);
  return a;
}

// ---- zip through libzip ----

std::string ZipStored(const std::vector<std::pair<std::string, std::string>>& members, const std::string& field) {
  zip_error_t err;
  zip_error_init(&err);
  zip_source_t* src = zip_source_buffer_create(nullptr, 0, 0, &err);
  if (src == nullptr) throw InternalError("libzip: " + std::string(zip_error_strerror(&err)));
  zip_source_keep(src);
  zip_t* za = zip_open_from_source(src, ZIP_TRUNCATE, &err);
  if (za == nullptr) {
    zip_source_free(src);
    throw InternalError("libzip: " + std::string(zip_error_strerror(&err)));
  }
  for (const auto& [name, data] : members) {
    zip_source_t* s = zip_source_buffer(za, data.data(), data.size(), 0);
    const zip_int64_t idx = s ? zip_file_add(za, name.c_str(), s, ZIP_FL_ENC_UTF_8) : -1;
    if (idx < 0) {
      if (s) zip_source_free(s);
      zip_discard(za);
      zip_source_free(src);
      throw InvalidInput(field, "libzip: cannot add " + name);
    }
    zip_set_file_compression(za, idx, ZIP_CM_STORE, 0);
    zip_file_set_mtime(za, idx, 315619200, 0);  // 1980-01-02: the same bytes every time
  }
  if (zip_close(za) < 0) {
    const std::string e = zip_strerror(za);
    zip_discard(za);
    zip_source_free(src);
    throw InternalError("libzip: " + e);
  }
  std::string out;
  if (zip_source_open(src) == 0) {
    zip_source_seek(src, 0, SEEK_END);
    const zip_int64_t size = zip_source_tell(src);
    zip_source_seek(src, 0, SEEK_SET);
    out.resize(static_cast<std::size_t>(std::max<zip_int64_t>(size, 0)));
    const zip_int64_t got = zip_source_read(src, out.data(), out.size());
    zip_source_close(src);
    if (got != size) out.clear();
  }
  zip_source_free(src);
  if (out.empty()) throw InternalError("libzip: the archive could not be read back");
  return out;
}

std::vector<std::pair<std::string, std::string>> ReadZip(std::string_view bytes, const std::string& field) {
  zip_error_t err;
  zip_error_init(&err);
  zip_source_t* src = zip_source_buffer_create(bytes.data(), bytes.size(), 0, &err);
  if (src == nullptr) throw InternalError("libzip: " + std::string(zip_error_strerror(&err)));
  zip_t* za = zip_open_from_source(src, ZIP_RDONLY | ZIP_CHECKCONS, &err);
  if (za == nullptr) {
    zip_source_free(src);
    throw InvalidInput(field, "not a zip archive (an .npz is one): " + std::string(zip_error_strerror(&err)));
  }
  std::unique_ptr<zip_t, void (*)(zip_t*)> guard(za, [](zip_t* z) { zip_discard(z); });
  const zip_int64_t n = zip_get_num_entries(za, 0);
  if (n < 0 || static_cast<std::size_t>(n) > kMaxNpzMembers) {
    throw InvalidInput(field, fmt::format("more than {} members: not a calibration npz", kMaxNpzMembers));
  }
  std::vector<std::pair<std::string, std::string>> out;
  for (zip_int64_t i = 0; i < n; ++i) {
    zip_stat_t st;
    zip_stat_init(&st);
    if (zip_stat_index(za, i, 0, &st) != 0 || !(st.valid & ZIP_STAT_SIZE) || !(st.valid & ZIP_STAT_NAME)) {
      throw InvalidInput(field, "a zip member cannot be read");
    }
    if (st.size > kMaxNpyBytes) throw InvalidInput(field, fmt::format("member {} is larger than {} bytes", st.name, kMaxNpyBytes));
    zip_file_t* zf = zip_fopen_index(za, i, 0);
    if (zf == nullptr) throw InvalidInput(field, fmt::format("member {} cannot be opened: {}", st.name, zip_strerror(za)));
    std::string data(st.size, '\0');
    const zip_int64_t got = st.size ? zip_fread(zf, data.data(), st.size) : 0;
    zip_fclose(zf);
    if (got != static_cast<zip_int64_t>(st.size)) throw InvalidInput(field, fmt::format("member {} is truncated or corrupt", st.name));
    out.emplace_back(st.name, std::move(data));
  }
  return out;
}

}  // namespace porthole::interop
