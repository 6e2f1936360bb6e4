// OpenCV FileStorage calibration files, YAML and XML (opencv_storage.h gives the keys and OpenCV's
// sources; docs/interop.md, "OpenCV FileStorage"): the reader and writer, and the formats
// opencv-yaml and opencv-xml of interop.h's list (pinhole ↔ opencv, cv::fisheye ↔ kannala-brandt).
#include "porthole/interop/opencv_storage.h"

#include <fmt/format.h>

#include <cmath>
#include <cstdlib>
#include <initializer_list>
#include <optional>

#include "porthole/camera/camera.h"
#include "porthole/core/error.h"
#include "porthole/interop/interop.h"
#include "porthole/interop/internal.h"
#include "porthole/interop/xml.h"
#include "porthole/interop/text.h"

namespace porthole::interop {
namespace {

using detail::Num;

constexpr std::size_t kMaxNumbers = 20;  // a node porthole reads holds at most 14 (+ slack)



// A node's content as the file gives it: its data (the numbers of a matrix or sequence, or a
// scalar) and, for a matrix, its declared rows and cols.
struct Node {
  std::string data;
  std::optional<std::string> rows, cols;
};

// ---- YAML: a linear scan for top-level keys (no recursion, no YAML library) ----

// The text after "<key>:" at the start of a line, through its indented continuation lines.
std::optional<std::string> YamlEntry(std::string_view y, std::string_view key) {
  std::size_t pos = 0;
  while (pos < y.size()) {
    const std::size_t eol = std::min(y.find('\n', pos), y.size());
    const std::string_view line = y.substr(pos, eol - pos);
    if (line.substr(0, key.size()) == key && line.size() > key.size() && line[key.size()] == ':') {
      std::size_t end = eol;
      while (end < y.size()) {
        const char first = end + 1 < y.size() ? y[end + 1] : '\n';
        if (first != ' ' && first != '\t' && first != '\n' && first != '#') break;
        end = std::min(y.find('\n', end + 1), y.size());
      }
      return std::string(y.substr(pos + key.size() + 1, end - pos - key.size() - 1));
    }
    pos = eol + 1;
  }
  return std::nullopt;
}

// The value of "<name>:" inside a YAML matrix entry (rows, cols), up to the end of its line.
std::optional<std::string> YamlSubkey(const std::string& entry, std::string_view name) {
  const std::string needle = std::string(name) + ":";
  for (std::size_t p = entry.find(needle); p != std::string::npos; p = entry.find(needle, p + 1)) {
    if (p > 0 && entry[p - 1] != ' ' && entry[p - 1] != '\t' && entry[p - 1] != '\n' && entry[p - 1] != '{' &&
        entry[p - 1] != ',') {
      continue;
    }
    const std::size_t start = p + needle.size();
    const std::size_t end = std::min(entry.find_first_of(",}\n", start), entry.size());
    return Trim(std::string_view(entry).substr(start, end - start));
  }
  return std::nullopt;
}

std::optional<Node> YamlNode(std::string_view y, std::string_view key, const std::string& field) {
  const auto entry = YamlEntry(y, key);
  if (!entry) return std::nullopt;
  Node n;
  std::size_t from = 0;
  if (const auto data = entry->find("data:"); data != std::string::npos) {
    from = data;
    n.rows = YamlSubkey(*entry, "rows");
    n.cols = YamlSubkey(*entry, "cols");
  }
  const auto open = entry->find('[', from);
  if (open == std::string::npos) {
    if (from != 0) throw InvalidInput(field + ": " + std::string(key), "expected data: [ … ]");
    std::string s = *entry;
    if (const auto hash = s.find(" #"); hash != std::string::npos) s.resize(hash);  // a trailing comment
    n.data = Unquote(Trim(s));
    return n;
  }
  const auto close = entry->find(']', open);
  if (close == std::string::npos) throw InvalidInput(field + ": " + std::string(key), "a list [ … ] without its ']'");
  n.data = entry->substr(open + 1, close - open - 1);
  return n;
}

// ---- XML: the children of <opencv_storage> ----

std::optional<Node> XmlNode(const XmlDocument& doc, std::string_view key) {
  const XmlElement* e = doc.Child(doc.root(), key);
  if (e == nullptr) return std::nullopt;
  Node n;
  if (const XmlElement* data = doc.Child(*e, "data")) {
    n.data = data->text;
    if (const XmlElement* r = doc.Child(*e, "rows")) n.rows = Trim(r->text);
    if (const XmlElement* c = doc.Child(*e, "cols")) n.cols = Trim(c->text);
  } else {
    n.data = Unquote(Trim(e->text));
  }
  return n;
}

// The node's numbers (separated by commas or white space), at most kMaxNumbers, each finite; a
// matrix's rows × cols must match their count.
std::vector<double> Numbers(const Node& n, const std::string& where) {
  std::vector<double> out;
  std::size_t p = 0;
  const std::string& s = n.data;
  while (p < s.size()) {
    p = s.find_first_not_of(" \t\r\n,", p);
    if (p == std::string::npos) break;
    const std::size_t end = std::min(s.find_first_of(" \t\r\n,", p), s.size());
    const std::string item = s.substr(p, end - p);
    char* stop = nullptr;
    const double v = std::strtod(item.c_str(), &stop);
    if (stop != item.c_str() + item.size() || !std::isfinite(v)) {
      throw InvalidInput(where, "'" + item.substr(0, 40) + "' is not a finite number");
    }
    if (out.size() == kMaxNumbers) throw InvalidInput(where, fmt::format("more than {} numbers", kMaxNumbers));
    out.push_back(v);
    p = end;
  }
  if (n.rows && n.cols) {
    char* e1 = nullptr;
    char* e2 = nullptr;
    const long rows = std::strtol(n.rows->c_str(), &e1, 10), cols = std::strtol(n.cols->c_str(), &e2, 10);
    if (*e1 != '\0' || *e2 != '\0' || rows < 1 || cols < 1 || rows > 64 || cols > 64) {
      throw InvalidInput(where, "rows and cols must be whole numbers from 1 to 64");
    }
    if (static_cast<std::size_t>(rows * cols) != out.size()) {
      throw InvalidInput(where, fmt::format("rows x cols = {} x {} but data holds {} numbers", rows, cols, out.size()));
    }
  }
  return out;
}

int Pixels(double v, const std::string& where) {
  if (!(v >= 1 && v <= 1e6 && v == std::floor(v))) {
    throw InvalidInput(where, "must be a whole number of pixels from 1 to 1000000");
  }
  return static_cast<int>(v);
}

// XML comments may not hold "--".
std::string XmlCommentText(std::string_view s) {
  std::string out;
  for (char c : s) {
    if (c == '-' && !out.empty() && out.back() == '-') out += ' ';
    out += c;
  }
  if (!out.empty() && out.back() == '-') out += ' ';
  return out;
}

}  // namespace

OpenCVStorageCalibration ParseOpenCVStorage(std::string_view text, bool xml, const std::string& field) {
  std::optional<XmlDocument> doc;
  if (xml) {
    doc = ParseXml(text, field);
    if (doc->root().name != "opencv_storage") {
      throw InvalidInput(field, "not an OpenCV FileStorage XML: the root element is <" + doc->root().name.substr(0, 40) +
                                    ">, not <opencv_storage>");
    }
  }
  const auto node = [&](std::string_view key) { return xml ? XmlNode(*doc, key) : YamlNode(text, key, field); };
  // The first of `keys` present, with the key found.
  const auto first = [&](std::initializer_list<std::string_view> keys) -> std::pair<std::string, std::optional<Node>> {
    for (const auto key : keys) {
      if (auto n = node(key)) return {std::string(key), std::move(n)};
    }
    return {"", std::nullopt};
  };
  OpenCVStorageCalibration c;
  const auto [k_key, k_node] = first({"camera_matrix", "cameraMatrix", "K"});
  if (!k_node) throw InvalidInput(field + ": camera_matrix", "missing (also looked for cameraMatrix, K)");
  const auto k = Numbers(*k_node, field + ": " + k_key);
  if (k.size() != 9 || k[1] != 0 || k[3] != 0 || k[6] != 0 || k[7] != 0 || k[8] != 1) {
    throw InvalidInput(field + ": " + k_key, "must be 3x3 [fx 0 cx; 0 fy cy; 0 0 1] (no skew)");
  }
  std::copy(k.begin(), k.end(), c.camera_matrix.begin());
  const auto [d_key, d_node] = first({"distortion_coefficients", "distCoeffs", "dist_coeffs", "D"});
  if (!d_node) throw InvalidInput(field + ": distortion_coefficients", "missing (also looked for distCoeffs, D)");
  c.distortion = Numbers(*d_node, field + ": " + d_key);
  const std::size_t n = c.distortion.size();

  // Which model: the file's marker, else cv::fisheye's names with 4 coefficients.
  std::optional<bool> fisheye;
  if (const auto m = node("fisheye_model")) {
    const auto v = Numbers(*m, field + ": fisheye_model");
    if (v.size() != 1) throw InvalidInput(field + ": fisheye_model", "must be one number (0 or 1)");
    fisheye = v[0] != 0;
  }
  if (const auto m = node("distortion_model")) {
    const std::string name = m->data;
    bool f = false;
    if (name == "fisheye" || name == "equidistant") {
      f = true;
    } else if (name != "plumb_bob" && name != "rational_polynomial") {
      throw InvalidInput(field + ": distortion_model", "'" + name.substr(0, 40) +
                                                           "' is not supported (plumb_bob, rational_polynomial, "
                                                           "fisheye, equidistant)");
    }
    if (fisheye && *fisheye != f) throw InvalidInput(field + ": distortion_model", "contradicts fisheye_model");
    fisheye = f;
  }
  c.fisheye = fisheye.value_or(k_key == "K" && d_key == "D" && n == 4);
  if (c.fisheye) {
    if (n != 4) throw InvalidInput(field + ": " + d_key, fmt::format("has {} entries; cv::fisheye has 4 (k1-k4)", n));
  } else {
    if (n != 4 && n != 5 && n != 8 && n != 12 && n != 14) {
      throw InvalidInput(field + ": " + d_key, fmt::format("has {} entries; OpenCV has 4, 5, 8, 12 or 14", n));
    }
    for (std::size_t i = 8; i < n; ++i) {
      if (c.distortion[i] != 0) {
        throw InvalidInput(field + ": " + d_key, "thin-prism s1-s4 and tilt tau_x, tau_y must be 0 "
                                                 "(porthole's opencv model has k1-k6, p1, p2)");
      }
    }
  }

  const auto [s_key, s_node] = first({"image_size", "imageSize"});
  if (s_node) {
    const auto size = Numbers(*s_node, field + ": " + s_key);
    if (size.size() != 2) throw InvalidInput(field + ": " + s_key, "must be [ width, height ]");
    c.width_px = Pixels(size[0], field + ": " + s_key);
    c.height_px = Pixels(size[1], field + ": " + s_key);
  } else {
    for (auto [key, out] : {std::pair<std::string_view, int*>{"image_width", &c.width_px}, {"image_height", &c.height_px}}) {
      const std::string where = field + ": " + std::string(key);
      const auto e = node(key);
      if (!e) throw InvalidInput(where, "missing (or image_size: [ w, h ])");
      const auto v = Numbers(*e, where);
      if (v.size() != 1) throw InvalidInput(where, "must be one whole number of pixels");
      *out = Pixels(v[0], where);
    }
  }
  return c;
}

std::string OpenCVStorageText(const OpenCVStorageCalibration& c, bool xml, std::string_view comment) {
  const auto list = [&](const auto& values, std::string_view sep) {
    std::string s;
    for (double v : values) s += (s.empty() ? "" : std::string(sep)) + Num(v);
    return s;
  };
  const std::size_t n = c.distortion.size();
  if (xml) {
    const auto matrix = [&](std::string_view name, int rows, int cols, const std::string& data) {
      return fmt::format("<{0} type_id=\"opencv-matrix\">\n  <rows>{1}</rows>\n  <cols>{2}</cols>\n  <dt>d</dt>\n"
                         "  <data>\n    {3}</data></{0}>\n",
                         name, rows, cols, data);
    };
    return fmt::format("<?xml version=\"1.0\"?>\n<opencv_storage>\n<!-- {} -->\n<image_width>{}</image_width>\n"
                       "<image_height>{}</image_height>\n<fisheye_model>{}</fisheye_model>\n{}{}</opencv_storage>\n",
                       XmlCommentText(comment), c.width_px, c.height_px, c.fisheye ? 1 : 0,
                       matrix("camera_matrix", 3, 3, list(c.camera_matrix, " ")),
                       matrix("distortion_coefficients", static_cast<int>(n), 1, list(c.distortion, " ")));
  }
  const auto matrix = [&](std::string_view name, int rows, int cols, const std::string& data) {
    return fmt::format("{}: !!opencv-matrix\n   rows: {}\n   cols: {}\n   dt: d\n   data: [ {} ]\n", name, rows, cols,
                       data);
  };
  std::string safe(comment);
  for (char& ch : safe) {
    if (ch == '\n') ch = ' ';
  }
  return fmt::format("%YAML:1.0\n---\n# {}\nimage_width: {}\nimage_height: {}\nfisheye_model: {}\n{}{}", safe,
                     c.width_px, c.height_px, c.fisheye ? 1 : 0, matrix("camera_matrix", 3, 3, list(c.camera_matrix, ", ")),
                     matrix("distortion_coefficients", static_cast<int>(n), 1, list(c.distortion, ", ")));
}

std::string OpenCVStereoText(const OpenCVStereo& s, bool xml, std::string_view comment) {
  const auto list = [&](const auto& values, std::string_view sep) {
    std::string out;
    for (double v : values) out += (out.empty() ? "" : std::string(sep)) + Num(v);
    return out;
  };
  const auto matrix = [&](std::string_view name, int rows, int cols, const auto& values) {
    if (xml) {
      return fmt::format("<{0} type_id=\"opencv-matrix\">\n  <rows>{1}</rows>\n  <cols>{2}</cols>\n  <dt>d</dt>\n"
                         "  <data>\n    {3}</data></{0}>\n",
                         name, rows, cols, list(values, " "));
    }
    return fmt::format("{}: !!opencv-matrix\n   rows: {}\n   cols: {}\n   dt: d\n   data: [ {} ]\n", name, rows, cols,
                       list(values, ", "));
  };
  const auto d = [&](const OpenCVStorageCalibration& c) { return static_cast<int>(c.distortion.size()); };
  const std::string body = matrix("K1", 3, 3, s.first.camera_matrix) + matrix("D1", d(s.first), 1, s.first.distortion) +
                           matrix("K2", 3, 3, s.second.camera_matrix) +
                           matrix("D2", d(s.second), 1, s.second.distortion) + matrix("R", 3, 3, s.r) +
                           matrix("T", 3, 1, s.t);
  if (xml) {
    return fmt::format("<?xml version=\"1.0\"?>\n<opencv_storage>\n<!-- {} -->\n<image_width>{}</image_width>\n"
                       "<image_height>{}</image_height>\n{}</opencv_storage>\n",
                       XmlCommentText(comment), s.first.width_px, s.first.height_px, body);
  }
  std::string safe(comment);
  for (char& ch : safe) {
    if (ch == '\n') ch = ' ';
  }
  return fmt::format("%YAML:1.0\n---\n# {}\nimage_width: {}\nimage_height: {}\n{}", safe, s.first.width_px,
                     s.first.height_px, body);
}

// ---- The formats opencv-yaml and opencv-xml of interop.h (the format list's reader and writer) ----

namespace {

using camera::Camera;
using camera::CameraModelId;
using OpenCV = camera::OpenCVModel;
using KB = camera::KannalaBrandtModel;

ReadResult ReadOpenCVStorage(const std::string& text, Format format, double pitch_mm, const std::string& field) {
  const OpenCVStorageCalibration c = ParseOpenCVStorage(text, format == Format::kOpenCVXml, field);
  const auto& k = c.camera_matrix;
  const auto& d = c.distortion;
  const auto s = detail::PixelSensor(c.width_px, c.height_px, pitch_mm);
  ReadResult r;
  if (c.fisheye) {
    r.calibration.camera = Camera{CameraModelId::kKannalaBrandt, s, {k[0], k[4], k[2], k[5], d[0], d[1], d[2], d[3]}};
    r.format_model = "fisheye, 4 coefficients";
  } else {
    const auto at = [&](std::size_t i) { return i < d.size() ? d[i] : 0.0; };
    r.calibration.camera = detail::OpenCVCamera(s, {k[0], k[4], k[2], k[5], at(0), at(1), at(2), at(3), at(4), at(5), at(6), at(7)});
    r.format_model = fmt::format("{} coefficients", d.size());
  }
  r.format = format;
  return r;
}

// The camera as a FileStorage calibration: opencv with the fewest of 4, 5, 8 coefficients that hold
// it exactly, kannala-brandt as cv::fisheye's 4.
OpenCVStorageCalibration ToOpenCVStorage(const Camera& cam, const std::string& field) {
  OpenCVStorageCalibration c;
  c.width_px = cam.sensor.width_px;
  c.height_px = cam.sensor.height_px;
  const auto& p = cam.params;
  const auto matrix = [&](double fx, double fy, double cx, double cy) {
    c.camera_matrix = {fx, 0, cx, 0, fy, cy, 0, 0, 1};
  };
  if (cam.model == CameraModelId::kKannalaBrandt) {
    c.fisheye = true;
    matrix(p[KB::kFx], p[KB::kFy], p[KB::kCx], p[KB::kCy]);
    c.distortion = {p[KB::kK1], p[KB::kK2], p[KB::kK3], p[KB::kK4]};
    return c;
  }
  if (cam.model != CameraModelId::kOpenCV) {
    detail::NoRepresentation(cam, "OpenCV FileStorage", field, "write opencv, brown (refit) or kannala-brandt (cv::fisheye)");
  }
  matrix(p[OpenCV::kFx], p[OpenCV::kFy], p[OpenCV::kCx], p[OpenCV::kCy]);
  const bool rational = p[OpenCV::kK4] != 0 || p[OpenCV::kK5] != 0 || p[OpenCV::kK6] != 0;
  const int n = rational ? 8 : p[OpenCV::kK3] != 0 ? 5 : 4;
  c.distortion.assign(p.begin() + OpenCV::kK1, p.begin() + OpenCV::kK1 + n);
  return c;
}

}  // namespace

namespace detail {

ReadResult ReadOpenCVStorageFile(const std::string& content, const ReadArgs& args) {
  ReadResult r = ReadOpenCVStorage(content, args.format, args.pixel_pitch_mm, args.field);
  r.calibration = NoSigmaRecord(r.camera(), args.format);
  return r;
}

WriteResult WriteOpenCVStorageFile(const calib::CalibrationRecord& cal, Format format, const std::string& field,
                                   const WriteExtras& /*extras*/) {
  const PixelCalibration pc = ToPixelFamily(cal, field);  // Brown: refit to opencv
  const Camera& cam = cal.camera;
  WriteResult w;
  w.exact = pc.exact;
  w.fit = pc.fit;
  const OpenCVStorageCalibration c = ToOpenCVStorage(pc.cal.camera, field);
  const std::string how = pc.exact ? "exact" : fmt::format("refit from {}: RMS {:.4f} px, max {:.4f} px over the image",
                                                           cam.model_name(), pc.fit.rms_px, pc.fit.max_px);
  w.content = OpenCVStorageText(c, format == Format::kOpenCVXml,
                                fmt::format("porthole calibration, {} ({})",
                                            c.fisheye ? "cv::fisheye model" : "OpenCV pinhole model", how));
  w.format_model = c.fisheye ? "fisheye, 4 coefficients" : fmt::format("{} coefficients", c.distortion.size());
  return w;
}

}  // namespace detail

}  // namespace porthole::interop
