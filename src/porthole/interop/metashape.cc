// Agisoft Metashape / PhotoScan calibration XML (metashape.h gives the camera model from the
// Metashape Professional 1.5 manual, Appendix C; docs/interop.md, "Metashape"): the reader and
// writer, and the format metashape of interop.h's list (frame ↔ opencv, fisheye ↔ kannala-brandt,
// exact or refit over the image, σ carried through its <covariance>).
#include "porthole/interop/metashape.h"

#include <fmt/format.h>

#include <sstream>

#include "porthole/camera/validate.h"
#include "porthole/core/error.h"
#include "porthole/interop/interop.h"
#include "porthole/interop/internal.h"
#include "porthole/interop/refit.h"
#include "porthole/interop/xml.h"
#include "porthole/interop/text.h"

namespace porthole::interop {
namespace {

using detail::Num;

double Number(const std::string& text, const std::string& field) {
  const std::string s = Trim(text);
  char* end = nullptr;
  const double v = std::strtod(s.c_str(), &end);
  if (s.empty() || end != s.c_str() + s.size() || !std::isfinite(v)) {
    throw InvalidInput(field, "'" + s.substr(0, 40) + "' is not a finite number");
  }
  return v;
}

int PixelCount(const std::string& text, const std::string& field) {
  const double v = Number(text, field);
  if (!(v >= 1 && v <= 1e6 && v == std::floor(v))) {
    throw InvalidInput(field, "must be a whole number of pixels from 1 to 1000000");
  }
  return static_cast<int>(v);
}

int IndexOf(std::string_view name) {
  for (int i = 0; i < kMetashapeNumParams; ++i) {
    if (kMetashapeNames[i] == name) return i;
  }
  return -1;
}

}  // namespace

MetashapeCalibration ParseMetashapeXml(std::string_view text, const std::string& field) {
  const XmlDocument doc = ParseXml(text, field);
  const XmlElement* cal = doc.root().name == "calibration" ? &doc.root() : doc.Find("calibration");
  if (cal == nullptr) {
    throw InvalidInput(field, "not a Metashape calibration: no <calibration> element");
  }
  const auto where = [&](std::string_view element) { return field + ": <" + std::string(element) + ">"; };
  MetashapeCalibration m;
  // Projection: <projection>frame</projection> (calibration export) or type="frame" (doc.xml).
  std::string projection = "frame";
  if (const XmlElement* e = doc.Child(*cal, "projection")) {
    projection = Trim(e->text);
  } else if (const auto t = XmlDocument::Attribute(*cal, "type")) {
    projection = *t;
  }
  if (projection != "frame" && projection != "fisheye") {
    throw InvalidInput(where("projection"), "'" + projection.substr(0, 40) +
                                                "' is not supported (porthole reads frame and fisheye)");
  }
  m.fisheye = projection == "fisheye";
  // Image size: <width>, <height>, or <resolution width=… height=…/>.
  const XmlElement* w = doc.Child(*cal, "width");
  const XmlElement* h = doc.Child(*cal, "height");
  if (w != nullptr && h != nullptr) {
    m.width_px = PixelCount(w->text, where("width"));
    m.height_px = PixelCount(h->text, where("height"));
  } else if (const XmlElement* r = doc.Child(*cal, "resolution")) {
    const auto rw = XmlDocument::Attribute(*r, "width"), rh = XmlDocument::Attribute(*r, "height");
    if (!rw || !rh) throw InvalidInput(where("resolution"), "needs width and height attributes");
    m.width_px = PixelCount(*rw, where("resolution") + " width");
    m.height_px = PixelCount(*rh, where("resolution") + " height");
  } else {
    throw InvalidInput(where("width"), "missing (the image size: <width>, <height>)");
  }
  // Parameters: each element at most once.
  std::array<std::optional<double>, kMetashapeNumParams> value;
  std::optional<double> fx, fy, skew;
  for (int c : cal->children) {
    const XmlElement& e = doc.elements[c];
    std::optional<double>* slot = nullptr;
    const int i = IndexOf(e.name);
    if (i >= 0) {
      slot = &value[i];
    } else if (e.name == "fx") {
      slot = &fx;
    } else if (e.name == "fy") {
      slot = &fy;
    } else if (e.name == "skew") {
      slot = &skew;
    }
    if (slot == nullptr) continue;  // date, projection, width, height, covariance, …
    if (slot->has_value()) throw InvalidInput(where(e.name), "given twice");
    *slot = Number(e.text, where(e.name));
  }
  if (fx || fy) {
    // Old PhotoScan: fx, fy, principal point from the image corner, skew.
    if (value[kMsF] || value[kMsB1] || value[kMsB2]) {
      throw InvalidInput(where("fx"), "a file gives either f (with b1, b2) or fx, fy (with skew), not both");
    }
    if (!fx || !fy) throw InvalidInput(where(fx ? "fy" : "fx"), "missing (fx and fy come together)");
    if (!value[kMsCx] || !value[kMsCy]) throw InvalidInput(where("cx"), "missing (PhotoScan's principal point)");
    m.photoscan_form = true;
    value[kMsF] = *fy;
    value[kMsB1] = *fx - *fy;
    if (skew) value[kMsB2] = *skew;
    *value[kMsCx] -= 0.5 * m.width_px;
    *value[kMsCy] -= 0.5 * m.height_px;
  } else if (skew) {
    throw InvalidInput(where("skew"), "belongs to PhotoScan's fx, fy form (Metashape writes b2)");
  }
  if (!value[kMsF]) throw InvalidInput(where("f"), "missing (the focal length in pixels)");
  for (int i = 0; i < kMetashapeNumParams; ++i) {
    m.present[i] = value[i].has_value();
    m.params[i] = value[i].value_or(0.0);
  }
  if (!(m.params[kMsF] > 0) || !(m.params[kMsF] + m.params[kMsB1] > 0)) {
    throw InvalidInput(where("f"), "the focal lengths f and f + b1 must be positive");
  }
  // Covariance: inside <calibration> (calibration export) or beside it (doc.xml's <sensor>).
  const XmlElement* cov = doc.Child(*cal, "covariance");
  if (cov == nullptr) cov = doc.Find("covariance");
  if (cov != nullptr) {
    if (m.photoscan_form) {
      throw InvalidInput(where("covariance"), "a covariance with PhotoScan's fx, fy form is not supported");
    }
    const XmlElement* names = doc.Child(*cov, "params");
    const XmlElement* coeffs = doc.Child(*cov, "coeffs");
    if (names == nullptr || coeffs == nullptr) {
      throw InvalidInput(where("covariance"), "needs <params> and <coeffs>");
    }
    std::vector<int> idx;
    std::istringstream ns(names->text);
    for (std::string n; ns >> n;) {
      const int i = IndexOf(n);
      if (i < 0) throw InvalidInput(where("covariance") + " <params>", "unknown parameter '" + n.substr(0, 40) + "'");
      for (int j : idx) {
        if (j == i) throw InvalidInput(where("covariance") + " <params>", "'" + n + "' named twice");
      }
      idx.push_back(i);
    }
    std::vector<double> c;
    std::istringstream cs(coeffs->text);
    for (std::string n; cs >> n;) {
      if (c.size() > idx.size() * idx.size()) break;
      c.push_back(Number(n, where("covariance") + " <coeffs>"));
    }
    if (idx.empty() || c.size() != idx.size() * idx.size()) {
      throw InvalidInput(where("covariance") + " <coeffs>",
                         fmt::format("needs {} numbers ({} parameters squared)", idx.size() * idx.size(), idx.size()));
    }
    m.covariance = Eigen::MatrixXd::Zero(kMetashapeNumParams, kMetashapeNumParams);
    for (std::size_t a = 0; a < idx.size(); ++a) {
      for (std::size_t b = 0; b < idx.size(); ++b) m.covariance(idx[a], idx[b]) = c[a * idx.size() + b];
      if (!(m.covariance(idx[a], idx[a]) > 0)) {
        throw InvalidInput(where("covariance"), "the variance of " + std::string(kMetashapeNames[idx[a]]) + " must be positive");
      }
    }
  }
  return m;
}

std::string MetashapeXml(const MetashapeCalibration& m) {
  std::string out = "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<calibration>\n";
  out += fmt::format("  <projection>{}</projection>\n  <width>{}</width>\n  <height>{}</height>\n",
                     m.fisheye ? "fisheye" : "frame", m.width_px, m.height_px);
  std::vector<int> listed;
  for (int i = 0; i < kMetashapeNumParams; ++i) {
    const bool always = i == kMsF || i == kMsCx || i == kMsCy || i == kMsK1 || i == kMsK2 ||
                        i == kMsK3 || i == kMsP1 || i == kMsP2;
    const bool has_variance = m.covariance.size() > 0 && m.covariance(i, i) > 0;
    if (always || m.params[i] != 0 || m.present[i] || has_variance) {
      out += fmt::format("  <{0}>{1}</{0}>\n", kMetashapeNames[i], Num(m.params[i]));
    }
    if (has_variance) listed.push_back(i);
  }
  if (!listed.empty()) {
    std::string names, coeffs;
    for (int a : listed) {
      names += (names.empty() ? "" : " ") + std::string(kMetashapeNames[a]);
      for (int b : listed) coeffs += (coeffs.empty() ? "" : " ") + Num(m.covariance(a, b));
    }
    out += fmt::format("  <covariance>\n    <params>{}</params>\n    <coeffs>{}</coeffs>\n  </covariance>\n",
                       names, coeffs);
  }
  out += "</calibration>\n";
  return out;
}

// ---- The format metashape of interop.h (the format list's reader and writer) ----

namespace {

using camera::Camera;
using camera::CameraModelId;
using OpenCV = camera::OpenCVModel;
using KB = camera::KannalaBrandtModel;
using detail::CarrySigma;
using detail::ConvertTo;
using detail::FreeFirst;
using detail::NoRepresentation;
using detail::OpenCVCamera;
using detail::PixelCalibration;
using detail::PixelSensor;
using detail::ToPixelFamily;

// A Metashape calibration read as porthole's opencv (frame) or kannala-brandt (fisheye) model:
// exact without b2, k4, p3, p4 (frame) or b2, p1–p4 (fisheye), else refit over the image.
ReadResult ReadMetashape(const std::string& text, double pitch_mm, const std::string& field) {
  const MetashapeCalibration m = ParseMetashapeXml(text, field);
  const auto s = PixelSensor(m.width_px, m.height_px, pitch_mm);
  const auto& q = m.params;
  const double fx = q[kMsF] + q[kMsB1], fy = q[kMsF];
  const double cx = 0.5 * m.width_px - 0.5 + q[kMsCx], cy = 0.5 * m.height_px - 0.5 + q[kMsCy];
  calib::CalibrationRecord in;
  in.free.assign(kMetashapeNumParams, false);
  const bool has_cov = m.covariance.size() > 0;
  for (int i = 0; i < kMetashapeNumParams; ++i) in.free[i] = has_cov ? m.covariance(i, i) > 0 : m.present[i];
  in.covariance = has_cov ? m.covariance
                          : Eigen::MatrixXd::Constant(kMetashapeNumParams, kMetashapeNumParams, NAN);
  in.has_covariance = has_cov;
  in.covariance_note = has_cov ? "" : "σ unknown: the Metashape file has no <covariance>";
  const std::vector<double> p(q.begin(), q.end());
  const MetashapeProjector src{m.fisheye, m.width_px, m.height_px};
  ReadResult r;
  r.format = Format::kMetashape;
  if (m.fisheye) {
    r.format_model = "fisheye";
    r.exact = q[kMsB2] == 0 && q[kMsP1] == 0 && q[kMsP2] == 0 && q[kMsP3] == 0 && q[kMsP4] == 0;
    const Camera start{CameraModelId::kKannalaBrandt, s, {fx, fy, cx, cy, q[kMsK1], q[kMsK2], q[kMsK3], q[kMsK4]}};
    camera::ValidateCamera(start, field);
    r.calibration = ConvertTo<KB>(src, p, in.free, in.covariance, in, start,
                                  FreeFirst(KB::kNumParams, KB::kNumParams), !r.exact, &r.fit);
  } else {
    r.format_model = m.photoscan_form ? "frame (PhotoScan fx, fy)" : "frame";
    r.exact = q[kMsB2] == 0 && q[kMsK4] == 0 && q[kMsP3] == 0 && q[kMsP4] == 0;
    // OpenCV's p1 is Metashape's P2 and its p2 Metashape's P1.
    const Camera start = OpenCVCamera(s, {fx, fy, cx, cy, q[kMsK1], q[kMsK2], q[kMsP2], q[kMsP1], q[kMsK3]});
    camera::ValidateCamera(start, field);
    r.calibration = ConvertTo<OpenCV>(src, p, in.free, in.covariance, in, start,
                                      FreeFirst(OpenCV::kNumParams, 9), !r.exact, &r.fit);
  }
  return r;
}

// The Metashape projector's parameters as a record (for CarrySigma's target side).
MetashapeCalibration ToMetashape(const calib::CalibrationRecord& in, const std::string& field,
                                 bool* exact, camera::ConversionFit* fit) {
  const PixelCalibration pc = ToPixelFamily(in, field);
  const Camera& c = pc.cal.camera;
  *exact = pc.exact;
  *fit = pc.fit;
  MetashapeCalibration m;
  m.width_px = c.sensor.width_px;
  m.height_px = c.sensor.height_px;
  const auto& p = c.params;
  std::vector<double> q(kMetashapeNumParams, 0.0);
  std::vector<bool> free_q(kMetashapeNumParams, false);
  bool refit_q = false;
  if (c.model == CameraModelId::kKannalaBrandt) {
    m.fisheye = true;
    q = {p[KB::kFy], p[KB::kCx] + 0.5 - 0.5 * m.width_px, p[KB::kCy] + 0.5 - 0.5 * m.height_px,
         p[KB::kFx] - p[KB::kFy], 0, p[KB::kK1], p[KB::kK2], p[KB::kK3], p[KB::kK4], 0, 0, 0, 0};
    for (int i : {kMsF, kMsCx, kMsCy, kMsB1, kMsK1, kMsK2, kMsK3, kMsK4}) free_q[i] = true;
  } else if (c.model == CameraModelId::kOpenCV) {
    q = {p[OpenCV::kFy], p[OpenCV::kCx] + 0.5 - 0.5 * m.width_px, p[OpenCV::kCy] + 0.5 - 0.5 * m.height_px,
         p[OpenCV::kFx] - p[OpenCV::kFy], 0, p[OpenCV::kK1], p[OpenCV::kK2], p[OpenCV::kK3], 0,
         p[OpenCV::kP2], p[OpenCV::kP1], 0, 0};
    for (int i : {kMsF, kMsCx, kMsCy, kMsB1, kMsK1, kMsK2, kMsK3, kMsP1, kMsP2}) free_q[i] = true;
    // OpenCV's rational k4–k6 have no Metashape term: refit with Metashape's k4 free.
    refit_q = p[OpenCV::kK4] != 0 || p[OpenCV::kK5] != 0 || p[OpenCV::kK6] != 0;
    if (refit_q) free_q[kMsK4] = true;
  } else {
    NoRepresentation(in.camera, "Metashape", field, "Metashape's frame and fisheye models hold opencv and kannala-brandt");
  }
  const MetashapeProjector dst{m.fisheye, m.width_px, m.height_px};
  const auto rays = refit::GridRays(c.sensor, [&](const Eigen::Vector2d& uv) { return c.Unproject(uv); });
  calib::CalibrationRecord out;
  camera::VisitModel(c.model, [&](auto model) {
    using S = decltype(model);
    if constexpr (S::kId == CameraModelId::kOpenCV || S::kId == CameraModelId::kKannalaBrandt) {
      const refit::ListProjector<S> src{c.sensor};
      if (refit_q) {
        const refit::ProjectedRays data = refit::ProjectRays(src, p, rays);
        const camera::ConversionFit f = refit::Fit(dst, &q, free_q, data.rays, data.px);
        *exact = false;
        *fit = f;
        if (!(f.rms_px <= kMaxRefitRmsPx) || !(q[kMsF] > 0)) {
          throw InvalidInput(field, fmt::format("the refit to Metashape's frame model misses the camera by RMS {:.3g} "
                                                "px (f {:g} px): Metashape's model cannot hold this camera",
                                                f.rms_px, q[kMsF]));
        }
      }
      CarrySigma(src, p, pc.cal.free, pc.cal.covariance, dst, q, free_q, rays, &out);
    }
  });
  std::copy(q.begin(), q.end(), m.params.begin());
  for (int i = 0; i < kMetashapeNumParams; ++i) m.present[i] = out.free[i];
  if (pc.cal.has_covariance && out.has_covariance) m.covariance = out.covariance;
  return m;
}

}  // namespace

namespace detail {

ReadResult ReadMetashapeFile(const std::string& content, const ReadArgs& args) {
  return ReadMetashape(content, args.pixel_pitch_mm, args.field);
}

WriteResult WriteMetashapeFile(const calib::CalibrationRecord& cal, Format /*format*/, const std::string& field,
                               const WriteExtras& /*extras*/) {
  WriteResult w;
  const MetashapeCalibration m = ToMetashape(cal, field, &w.exact, &w.fit);
  w.content = MetashapeXml(m);
  w.format_model = m.fisheye ? "fisheye" : "frame";
  w.sigma_written = m.covariance.size() > 0;
  return w;
}

}  // namespace detail

}  // namespace porthole::interop
