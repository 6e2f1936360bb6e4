// Measure (measure.h): image points → triangulated points and lengths with σ.
#include "porthole/measure/measure.h"

#include <fmt/format.h>

#include <charconv>
#include <cmath>
#include <map>
#include <set>

#include "porthole/calib/rig.h"
#include "porthole/core/error.h"

namespace porthole::measure {
namespace {

std::string Trim(std::string_view s) {
  const auto a = s.find_first_not_of(" \t\r");
  if (a == std::string_view::npos) return "";
  const auto b = s.find_last_not_of(" \t\r");
  return std::string(s.substr(a, b - a + 1));
}

bool ParseDouble(const std::string& s, double* v) {
  const char* end = s.data() + s.size();
  const auto r = std::from_chars(s.data(), end, *v);
  return r.ec == std::errc() && r.ptr == end && std::isfinite(*v);
}

}  // namespace

std::vector<ImagePoint> ParsePointsCsv(std::string_view text, const Rig& rig, const std::string& field,
                                       const std::string& origin) {
  std::vector<ImagePoint> out;
  std::size_t line_no = 0, pos = 0;
  while (pos <= text.size()) {
    const std::size_t eol = std::min(text.find('\n', pos), text.size());
    const std::string line = Trim(text.substr(pos, eol - pos));
    pos = eol + 1;
    ++line_no;
    if (line.empty() || line[0] == '#') continue;
    std::vector<std::string> cells;
    std::size_t start = 0;
    while (true) {
      const std::size_t comma = line.find(',', start);
      cells.push_back(Trim(std::string_view(line).substr(start, comma == std::string::npos ? std::string::npos : comma - start)));
      if (comma == std::string::npos) break;
      start = comma + 1;
    }
    const std::string where = fmt::format("{}:{}", origin, line_no);
    if (cells.size() == 5 && cells[0] == "frame" && out.empty()) continue;  // the header
    if (cells.size() != 5) {
      throw InvalidInput(field, fmt::format("{}: {} columns; expected frame,camera,id,u_px,v_px", where, cells.size()));
    }
    ImagePoint p;
    p.where = where;
    p.frame = cells[0];
    if (p.frame.empty()) throw InvalidInput(field, where + ": empty frame");
    try {
      p.camera = CameraIndex(rig, cells[1], "camera");
    } catch (const InvalidInput& e) {
      throw InvalidInput(field, where + ": " + std::string(e.what()).substr(e.field().size() + 2));
    }
    int id = -1;
    const auto r = std::from_chars(cells[2].data(), cells[2].data() + cells[2].size(), id);
    if (r.ec != std::errc() || r.ptr != cells[2].data() + cells[2].size() || id < 0) {
      throw InvalidInput(field, fmt::format("{}: id '{}' must be a whole number >= 0", where, cells[2]));
    }
    p.id = id;
    double u, v;
    if (!ParseDouble(cells[3], &u) || !ParseDouble(cells[4], &v)) {
      throw InvalidInput(field, fmt::format("{}: u_px, v_px must be numbers ('{}', '{}')", where, cells[3], cells[4]));
    }
    p.pixel_px = Eigen::Vector2d(u, v);
    out.push_back(std::move(p));
  }
  if (out.empty()) throw InvalidInput(field, origin + ": no points (expected lines frame,camera,id,u_px,v_px)");
  return out;
}

std::vector<ImagePoint> PointsFromDetections(const std::vector<calib::ImageDetections>& detections, int camera,
                                             const std::string& origin) {
  std::vector<ImagePoint> out;
  for (const auto& d : detections) {
    for (std::size_t i = 0; i < d.ids.size(); ++i) {
      out.push_back({calib::FrameName(d.image), camera, d.ids[i], d.points_px[i],
                     fmt::format("{}, image {}", origin, d.image)});
    }
  }
  return out;
}

MeasureResult Measure(const Rig& input_rig, const std::vector<ImagePoint>& points, const MeasureOptions& options) {
  MeasureResult res;
  // On a plane with an uncertain distance: that distance joins the parameters (its error is common
  // to every point).
  Rig plane_rig;
  std::optional<Plane> plane = options.plane;
  if (plane && plane->sigma_mm > 0) {
    plane_rig = input_rig;
    const auto n = plane_rig.covariance.rows();
    plane_rig.covariance.conservativeResize(n + 1, n + 1);
    plane_rig.covariance.row(n).setZero();
    plane_rig.covariance.col(n).setZero();
    plane_rig.covariance(n, n) = plane->sigma_mm * plane->sigma_mm;
    plane->covariance_index = static_cast<int>(n);
  }
  const Rig& rig = plane && plane->sigma_mm > 0 ? plane_rig : input_rig;
  if (plane && options.laser_pair) throw InvalidInput("laser_pair", "give a plane or a laser pair, not both");
  if ((plane || options.laser_pair) &&
      (options.plane_camera < 0 || options.plane_camera >= static_cast<int>(rig.cameras.size()))) {
    throw InvalidInput("plane_camera", fmt::format("{} is not a camera of the rig", options.plane_camera));
  }
  res.covariance_note = options.calibration_sigma ? rig.covariance_note : "not included (image noise only)";
  if (options.sigma_px > 0) {
    res.sigma_px = options.sigma_px;
    res.sigma_px_from = "given";
  } else if (options.sigma_px == 0 && rig.sigma0_px > 0) {
    res.sigma_px = rig.sigma0_px;
    res.sigma_px_from = "the rig calibration's sigma0: the target detector's noise; give `sigma_px` for points "
                        "placed otherwise";
  } else {
    throw InvalidInput("sigma_px", "must be a positive number of pixels (the rig file holds no sigma0 to default to)");
  }
  if (!std::isfinite(res.sigma_px)) throw InvalidInput("sigma_px", "must be finite");
  // (frame, id) → camera → pixel; checks.
  std::map<std::pair<std::string, int>, std::map<int, const ImagePoint*>> by_point;
  for (const ImagePoint& p : points) {
    if (p.camera < 0 || p.camera >= static_cast<int>(rig.cameras.size())) {
      throw InvalidInput("points", fmt::format("{}: camera {} is not in the rig", p.where, p.camera));
    }
    const camera::Sensor& s = rig.cameras[p.camera].camera.sensor;
    if (!(p.pixel_px.x() >= -0.5 && p.pixel_px.y() >= -0.5 && p.pixel_px.x() <= s.width_px - 0.5 &&
          p.pixel_px.y() <= s.height_px - 0.5)) {
      throw InvalidInput("points", fmt::format("{}: id {} at ({}, {}) px is outside {}'s {} × {} image", p.where, p.id,
                                               p.pixel_px.x(), p.pixel_px.y(), rig.cameras[p.camera].name, s.width_px,
                                               s.height_px));
    }
    auto& cams = by_point[{p.frame, p.id}];
    const auto [it, fresh] = cams.emplace(p.camera, &p);
    if (!fresh) {
      throw InvalidInput("points", fmt::format("{}: frame {}, id {} in {} a second time (first at {})", p.where,
                                               p.frame, p.id, rig.cameras[p.camera].name, it->second->where));
    }
  }
  TriangulateOptions to;
  to.sigma_px = res.sigma_px;
  to.calibration_sigma = options.calibration_sigma;
  to.mismatch_p = options.mismatch_p;
  std::map<std::pair<std::string, int>, int> index;  // (frame, id) → res.points
  std::vector<std::vector<Observation>> all_obs;
  // A laser scaler: each frame's plane from its two dots, its σ a parameter of that frame.
  std::map<std::string, Plane> frame_plane;
  Rig laser_rig;
  const bool laser = options.laser_pair.has_value();
  if (laser) {
    const int ida = static_cast<int>((*options.laser_pair)[0]), idb = static_cast<int>((*options.laser_pair)[1]);
    const double sep = (*options.laser_pair)[2];
    laser_rig = rig;
    std::set<std::string> frames;
    for (const auto& [key, cams] : by_point) frames.insert(key.first);
    for (const std::string& f : frames) {
      const auto dot = [&](int id) -> const ImagePoint* {
        const auto it = by_point.find({f, id});
        if (it == by_point.end()) return nullptr;
        const auto c = it->second.find(options.plane_camera);
        return c == it->second.end() ? nullptr : c->second;
      };
      const ImagePoint *a = dot(ida), *b = dot(idb);
      if (!a || !b) {
        throw InvalidInput("laser_pair", fmt::format("frame {}: laser dot id {} not measured in {}", f, a ? idb : ida,
                                                     rig.cameras[options.plane_camera].name));
      }
      const auto r = RangeFromLaserPair(rig.cameras[options.plane_camera], a->pixel_px, b->pixel_px, sep, res.sigma_px);
      if (!r) {
        throw InvalidInput("laser_pair", fmt::format("frame {}: no range puts the dots' rays {:g} mm apart ({}, {})", f,
                                                     sep, a->where, b->where));
      }
      res.laser_ranges.push_back({f, r->range_mm, r->sigma_mm});
      const auto n = laser_rig.covariance.rows();
      laser_rig.covariance.conservativeResize(n + 1, n + 1);
      laser_rig.covariance.row(n).setZero();
      laser_rig.covariance.col(n).setZero();
      laser_rig.covariance(n, n) = r->sigma_mm * r->sigma_mm;
      frame_plane[f] = Plane{Eigen::Vector3d::UnitZ(), r->range_mm, r->sigma_mm, static_cast<int>(n)};
    }
  }
  const Rig& mrig = laser ? laser_rig : rig;
  if (plane || laser) {  // one camera and the plane
    for (const auto& [key, cams] : by_point) {
      const auto it = cams.find(options.plane_camera);
      if (it == cams.end()) {
        throw InvalidInput("points", fmt::format("frame {}, id {}: not seen by {}, the camera of the plane ({})",
                                                 key.first, key.second, rig.cameras[options.plane_camera].name,
                                                 cams.begin()->second->where));
      }
      MeasuredPoint m;
      m.frame = key.first;
      m.id = key.second;
      m.cameras = {options.plane_camera};
      m.pixels_px = {it->second->pixel_px};
      TriangulateOptions po;
      po.sigma_px = res.sigma_px;
      po.calibration_sigma = options.calibration_sigma;
      m.point = IntersectPlane(mrig, {options.plane_camera, it->second->pixel_px},
                               laser ? frame_plane.at(key.first) : *plane, po);
      if (!m.point.ok) ++res.n_failed;
      index[key] = static_cast<int>(res.points.size());
      res.points.push_back(std::move(m));
    }
  }
  for (const auto& [key, cams] : by_point) {
    if (plane || laser) break;
    if (cams.size() < 2) {
      if (!options.skip_unpaired) {
        throw InvalidInput("points", fmt::format("frame {}, id {}: seen by {} only ({}); a 3-D point needs two "
                                                 "cameras (`skip_unpaired` skips such points)",
                                                 key.first, key.second, rig.cameras[cams.begin()->first].name,
                                                 cams.begin()->second->where));
      }
      ++res.n_unpaired;
      continue;
    }
    MeasuredPoint m;
    m.frame = key.first;
    m.id = key.second;
    std::vector<Observation> obs;
    for (const auto& [k, p] : cams) {
      obs.push_back({k, p->pixel_px});
      m.cameras.push_back(k);
      m.pixels_px.push_back(p->pixel_px);
    }
    all_obs.push_back(std::move(obs));
    index[key] = static_cast<int>(res.points.size());
    res.points.push_back(std::move(m));
  }
  std::vector<Point> tri =
      plane || laser ? std::vector<Point>{} : TriangulateMany(rig, all_obs, to, options.num_threads);
  for (std::size_t i = 0; i < tri.size(); ++i) {
    res.points[i].point = std::move(tri[i]);
    if (!res.points[i].point.ok) ++res.n_failed;
    if (res.points[i].point.ok && res.points[i].point.mismatched) ++res.n_mismatched;
  }
  if (res.points.empty() && res.n_unpaired > 0) {
    throw InvalidInput("points", fmt::format("no point is seen by two cameras ({} seen by one only): are the frames "
                                             "named alike in every camera?", res.n_unpaired));
  }
  if (!res.points.empty() && res.n_failed == static_cast<int>(res.points.size())) {
    const auto& m = res.points.front();
    throw InvalidInput("points", fmt::format("no point could be triangulated (frame {}, id {}: {})", m.frame, m.id,
                                             m.point.why));
  }
  // Lengths.
  std::set<std::string> frames;
  for (const auto& p : res.points) frames.insert(p.frame);
  for (const auto& [a, b] : options.lengths) {
    if (a == b) throw InvalidInput("lengths", fmt::format("{},{}: a length needs two different ids", a, b));
    int found = 0;
    bool seen_a = false, seen_b = false;
    for (const std::string& f : frames) {
      const auto ia = index.find({f, a}), ib = index.find({f, b});
      seen_a |= ia != index.end();
      seen_b |= ib != index.end();
      if (ia == index.end() || ib == index.end()) continue;
      ++found;
      MeasuredLength l;
      l.frame = f;
      l.id_a = a;
      l.id_b = b;
      const Point& pa = res.points[ia->second].point;
      const Point& pb = res.points[ib->second].point;
      if (!pa.ok || !pb.ok) {
        l.why = fmt::format("id {} not triangulated: {}", pa.ok ? b : a, pa.ok ? pb.why : pa.why);
      } else {
        l.length = MeasureLength(mrig, pa, pb);
        l.ok = true;
      }
      res.lengths.push_back(l);
    }
    if (found == 0) {
      const std::string what = !seen_a && !seen_b ? fmt::format("ids {} and {} are not measured", a, b)
                               : !seen_a          ? fmt::format("id {} is not measured", a)
                               : !seen_b          ? fmt::format("id {} is not measured", b)
                                                  : fmt::format("no frame holds both ids {} and {}", a, b);
      throw InvalidInput("lengths", fmt::format("{},{}: {} (by two cameras)", a, b, what));
    }
  }
  const int n_ok = static_cast<int>(res.points.size()) - res.n_failed;
  if (res.n_unpaired > 0) {
    res.warnings.push_back(fmt::format("{} points seen by one camera only were skipped", res.n_unpaired));
  }
  if (res.n_failed > 0) res.warnings.push_back(fmt::format("{} points could not be triangulated (why: in each)", res.n_failed));
  // Rays that do not meet: expected for a fraction mismatch_p of correct points; said when more are.
  const double expected = options.mismatch_p * n_ok;
  if (res.n_mismatched > 0 && res.n_mismatched > expected + 3 * std::sqrt(expected)) {
    std::string w = fmt::format("{} of {} points have rays that do not meet within the image noise (p < {:g}; "
                                "{:.1f} expected by chance): points matched wrongly, or `sigma_px` too small",
                                res.n_mismatched, n_ok, options.mismatch_p, expected);
    if (n_ok >= 5 && 2 * res.n_mismatched > n_ok) {
      w += "; most points are: are the image points given in the rig's camera order?";
    }
    res.warnings.push_back(w);
  }
  return res;
}

bool SetOneCamera(MeasureOptions* options, const std::optional<std::vector<double>>& plane,
                  std::optional<double> range_mm, const std::optional<std::vector<double>>& laser_pair,
                  double plane_sigma_mm) {
  const int given = static_cast<int>(plane.has_value()) + static_cast<int>(range_mm.has_value()) +
                    static_cast<int>(laser_pair.has_value());
  if (given > 1) throw InvalidInput("plane", "give one of `plane`, `range_mm` and `laser_pair`");
  if (!(plane_sigma_mm >= 0) || !std::isfinite(plane_sigma_mm)) throw InvalidInput("plane_sigma_mm", "must be >= 0 mm");
  if (given == 0) {
    if (plane_sigma_mm != 0) throw InvalidInput("plane_sigma_mm", "goes with `plane` or `range_mm`");
    return false;
  }
  if (laser_pair) {
    const auto& v = *laser_pair;
    if (v.size() != 3 || !(v[0] >= 0) || !(v[1] >= 0) || v[0] != std::floor(v[0]) || v[1] != std::floor(v[1]) ||
        !(v[2] > 0) || !std::isfinite(v[2]) || v[0] > 2e9 || v[1] > 2e9) {
      throw InvalidInput("laser_pair", fmt::format("give 3 numbers: the two dots' ids and the beams' separation in "
                                                   "mm (got {})", v.size()));
    }
    if (plane_sigma_mm != 0) {
      throw InvalidInput("plane_sigma_mm", "the laser pair gives each frame's range with its own sigma");
    }
    options->laser_pair = std::array<double, 3>{v[0], v[1], v[2]};
    return true;
  }
  Plane pl;
  pl.sigma_mm = plane_sigma_mm;
  if (range_mm) {
    if (!(*range_mm > 0) || !std::isfinite(*range_mm)) throw InvalidInput("range_mm", "must be > 0 mm");
    pl.distance_mm = *range_mm;
  } else {
    const auto& v = *plane;
    const Eigen::Vector3d n = v.size() == 4 ? Eigen::Vector3d(v[0], v[1], v[2]) : Eigen::Vector3d::Zero();
    if (v.size() != 4 || !n.allFinite() || !(n.norm() > 0) || !std::isfinite(v[3])) {
      throw InvalidInput("plane", fmt::format("give 4 numbers nx, ny, nz, d_mm: the plane n.x = d in the camera's "
                                              "frame, mm (got {}{})", v.size(), v.size() == 4 ? ", not all finite" : ""));
    }
    pl.normal = n.normalized();
    pl.distance_mm = v[3] / n.norm();
  }
  options->plane = pl;
  return true;
}

ScaleBarCheck CheckScaleBar(const MeasureResult& r, const ScaleBar& bar) {
  if (!(bar.length_mm > 0) || !std::isfinite(bar.length_mm)) {
    throw InvalidInput("scale_bar", fmt::format("{},{},{}: the length must be a positive number of mm", bar.id_a,
                                                bar.id_b, bar.length_mm));
  }
  if (bar.id_a == bar.id_b) throw InvalidInput("scale_bar", "the two ends must be different ids");
  ScaleBarCheck c;
  c.bar = bar;
  std::map<std::string, std::pair<const MeasuredPoint*, const MeasuredPoint*>> ends;
  for (const auto& p : r.points) {
    if (!p.point.ok) continue;
    if (p.id == bar.id_a) ends[p.frame].first = &p;
    if (p.id == bar.id_b) ends[p.frame].second = &p;
  }
  for (const auto& l : r.lengths) {
    if (!l.ok || !((l.id_a == bar.id_a && l.id_b == bar.id_b) || (l.id_a == bar.id_b && l.id_b == bar.id_a))) continue;
    const auto it = ends.find(l.frame);
    if (it == ends.end() || !it->second.first || !it->second.second) continue;
    const MeasuredPoint &a = *it->second.first, &b = *it->second.second;
    ScaleBarCheck::Row row;
    row.frame = l.frame;
    row.range_mm = (0.5 * (a.point.x_mm + b.point.x_mm)).norm();
    // The first camera that saw both ends.
    row.image_px = Eigen::Vector2d::Constant(NAN);
    for (std::size_t i = 0; i < a.cameras.size(); ++i) {
      for (std::size_t j = 0; j < b.cameras.size(); ++j) {
        if (a.cameras[i] == b.cameras[j] && !row.image_px.allFinite()) row.image_px = 0.5 * (a.pixels_px[i] + b.pixels_px[j]);
      }
    }
    row.length_mm = l.length.length_mm;
    row.error_mm = l.length.length_mm - bar.length_mm;
    row.sigma_mm = l.length.sigma_mm;
    row.sigma_image_mm = l.length.sigma_image_mm;
    row.sigma_calibration_mm = l.length.sigma_calibration_mm;
    c.rows.push_back(row);
  }
  if (c.rows.empty()) {
    throw InvalidInput("scale_bar", fmt::format("{},{}: no frame measured both ends (by two cameras)", bar.id_a,
                                                bar.id_b));
  }
  const double n = static_cast<double>(c.rows.size());
  double sum = 0, sum_cal = 0, sum_img2 = 0;
  double lo = INFINITY, hi = 0;
  for (const auto& row : c.rows) {
    sum += row.error_mm;
    sum_cal += row.sigma_calibration_mm;
    sum_img2 += row.sigma_image_mm * row.sigma_image_mm;
    lo = std::min(lo, row.range_mm);
    hi = std::max(hi, row.range_mm);
  }
  c.mean_error_mm = sum / n;
  c.mean_error_percent = 100 * c.mean_error_mm / bar.length_mm;
  c.sigma_mean_mm = std::sqrt(std::pow(sum_cal / n, 2) + sum_img2 / n / n);
  double ss = 0;
  for (const auto& row : c.rows) ss += std::pow(row.error_mm - c.mean_error_mm, 2);
  c.sd_error_mm = c.rows.size() > 1 ? std::sqrt(ss / (n - 1)) : NAN;
  c.z = c.sigma_mean_mm > 0 ? c.mean_error_mm / c.sigma_mean_mm : INFINITY;
  c.consistent = std::abs(c.z) <= 3;
  constexpr double kBin = 500;
  for (double start = std::floor(lo / kBin) * kBin; start <= hi; start += kBin) {
    ScaleBarCheck::Bin b;
    b.range_min_mm = start;
    b.range_max_mm = start + kBin;
    double e = 0, e2 = 0, s2 = 0;
    for (const auto& row : c.rows) {
      if (row.range_mm < start || row.range_mm >= start + kBin) continue;
      ++b.n;
      e += row.error_mm;
      e2 += row.error_mm * row.error_mm;
      s2 += row.sigma_mm * row.sigma_mm;
    }
    if (b.n == 0) continue;
    b.mean_error_mm = e / b.n;
    b.rms_error_mm = std::sqrt(e2 / b.n);
    b.rms_sigma_mm = std::sqrt(s2 / b.n);
    c.by_range.push_back(b);
  }
  c.verdict = c.consistent
                  ? fmt::format("the scale bar measures {:+.3f} mm ({:+.3f} %) off over {} frames, within 3 sigma "
                                "({:.3f} mm): the rig calibration holds",
                                c.mean_error_mm, c.mean_error_percent, c.rows.size(), c.sigma_mean_mm)
                  : fmt::format("the scale bar measures {:+.3f} mm ({:+.3f} %) off over {} frames, {:.1f} sigma "
                                "({:.3f} mm): the rig calibration does not hold for it (a camera moved in its "
                                "housing, a port changed, or the bar's length is wrong)",
                                c.mean_error_mm, c.mean_error_percent, c.rows.size(), std::abs(c.z), c.sigma_mean_mm);
  return c;
}

nlohmann::ordered_json ScaleBarToJson(const ScaleBarCheck& c) {
  using Json = nlohmann::ordered_json;
  const auto num = [](double v) { return std::isfinite(v) ? Json(v) : Json(nullptr); };
  Json rows = Json::array(), bins = Json::array();
  for (const auto& r : c.rows) {
    rows.push_back({{"frame", r.frame}, {"range_mm", r.range_mm}, {"image_px", {num(r.image_px.x()), num(r.image_px.y())}},
                    {"length_mm", r.length_mm}, {"error_mm", r.error_mm}, {"sigma_mm", num(r.sigma_mm)},
                    {"sigma_image_mm", num(r.sigma_image_mm)}, {"sigma_calibration_mm", num(r.sigma_calibration_mm)}});
  }
  for (const auto& b : c.by_range) {
    bins.push_back({{"range_min_mm", b.range_min_mm}, {"range_max_mm", b.range_max_mm}, {"n", b.n},
                    {"mean_error_mm", b.mean_error_mm}, {"rms_error_mm", b.rms_error_mm},
                    {"rms_sigma_mm", b.rms_sigma_mm}});
  }
  return {{"id_a", c.bar.id_a}, {"id_b", c.bar.id_b}, {"length_mm", c.bar.length_mm}, {"n_frames", c.rows.size()},
          {"mean_error_mm", c.mean_error_mm}, {"mean_error_percent", c.mean_error_percent},
          {"sigma_mean_mm", c.sigma_mean_mm}, {"sd_error_mm", num(c.sd_error_mm)}, {"z", num(c.z)},
          {"consistent", c.consistent}, {"verdict", c.verdict}, {"by_range", bins}, {"frames", rows}};
}

ScaleBarCheck ScaleBarFromJson(const nlohmann::json& in, const std::string& field) {
  const nlohmann::json* j = &in;
  if (in.is_object() && in.contains("measure")) {
    const auto& m = in["measure"];
    if (!m.is_object() || !m.contains("scale_bar")) {
      throw InvalidInput(field, "a measure output without a scale-bar check (measure with a scale bar)");
    }
    j = &m["scale_bar"];
  }
  std::string key;
  const auto number = [&](const nlohmann::json& o, const char* k, bool nullable = false) {
    key = k;
    if (!o.is_object() || !o.contains(k)) throw InvalidInput(field, fmt::format("{}: missing", key));
    const auto& v = o[k];
    if (v.is_null() && nullable) return double(NAN);
    if (!v.is_number() || !std::isfinite(v.get<double>())) throw InvalidInput(field, fmt::format("{}: not a number", key));
    return v.get<double>();
  };
  ScaleBarCheck c;
  c.bar.id_a = int(number(*j, "id_a"));
  c.bar.id_b = int(number(*j, "id_b"));
  c.bar.length_mm = number(*j, "length_mm");
  if (!(c.bar.length_mm > 0)) throw InvalidInput(field, "length_mm: must be > 0");
  c.mean_error_mm = number(*j, "mean_error_mm");
  c.mean_error_percent = number(*j, "mean_error_percent");
  c.sigma_mean_mm = number(*j, "sigma_mean_mm");
  c.sd_error_mm = number(*j, "sd_error_mm", true);
  c.z = number(*j, "z", true);
  if (!j->contains("consistent") || !(*j)["consistent"].is_boolean()) throw InvalidInput(field, "consistent: missing");
  c.consistent = (*j)["consistent"].get<bool>();
  if (j->contains("verdict") && (*j)["verdict"].is_string()) c.verdict = (*j)["verdict"].get<std::string>();
  if (!j->contains("frames") || !(*j)["frames"].is_array() || (*j)["frames"].empty()) {
    throw InvalidInput(field, "frames: a list of the bar's frames");
  }
  for (std::size_t i = 0; i < (*j)["frames"].size(); ++i) {
    const auto& f = (*j)["frames"][i];
    ScaleBarCheck::Row r;
    if (f.is_object() && f.contains("frame") && f["frame"].is_string()) r.frame = f["frame"].get<std::string>();
    r.range_mm = number(f, "range_mm");
    r.length_mm = number(f, "length_mm");
    r.error_mm = number(f, "error_mm");
    r.sigma_mm = number(f, "sigma_mm", true);
    r.sigma_image_mm = number(f, "sigma_image_mm", true);
    r.sigma_calibration_mm = number(f, "sigma_calibration_mm", true);
    key = "image_px";
    if (!f.contains("image_px") || !f["image_px"].is_array() || f["image_px"].size() != 2) {
      throw InvalidInput(field, fmt::format("frames[{}].image_px: a pair [u, v]", i));
    }
    for (int k = 0; k < 2; ++k) {
      const auto& v = f["image_px"][k];
      r.image_px[k] = v.is_number() ? v.get<double>() : NAN;
    }
    c.rows.push_back(r);
  }
  if (j->contains("by_range") && (*j)["by_range"].is_array()) {
    for (const auto& b : (*j)["by_range"]) {
      ScaleBarCheck::Bin bin;
      bin.range_min_mm = number(b, "range_min_mm");
      bin.range_max_mm = number(b, "range_max_mm");
      bin.n = int(number(b, "n"));
      bin.mean_error_mm = number(b, "mean_error_mm");
      bin.rms_error_mm = number(b, "rms_error_mm");
      bin.rms_sigma_mm = number(b, "rms_sigma_mm", true);
      c.by_range.push_back(bin);
    }
  }
  return c;
}

namespace {
nlohmann::ordered_json LaserRangesJson(const std::vector<FrameRange>& v) {
  nlohmann::ordered_json a = nlohmann::ordered_json::array();
  for (const auto& f : v) a.push_back({{"frame", f.frame}, {"range_mm", f.range_mm}, {"sigma_mm", f.sigma_mm}});
  return a;
}
}  // namespace

nlohmann::ordered_json MeasureToJson(const MeasureResult& r, const Rig& rig) {
  using Json = nlohmann::ordered_json;
  const auto num = [](double v) { return std::isfinite(v) ? Json(v) : Json(nullptr); };
  const auto vec = [&](const Eigen::Vector3d& v) { return Json{num(v.x()), num(v.y()), num(v.z())}; };
  Json points = Json::array();
  for (const auto& m : r.points) {
    Json cams = Json::array();
    for (int k : m.cameras) cams.push_back(rig.cameras[k].name);
    Json j = {{"frame", m.frame}, {"id", m.id}, {"cameras", cams}, {"ok", m.point.ok}};
    if (!m.point.ok) {
      j["why"] = m.point.why;
      points.push_back(j);
      continue;
    }
    const Point& p = m.point;
    j["x_mm"] = vec(p.x_mm);
    j["sigma_mm"] = vec(p.covariance_mm2.diagonal().cwiseSqrt());
    j["sigma_image_mm"] = vec(p.covariance_image_mm2.diagonal().cwiseSqrt());
    Json cov = Json::array();
    for (int a = 0; a < 3; ++a) cov.push_back(vec(p.covariance_mm2.row(a).transpose()));
    j["covariance_mm2"] = cov;
    j["miss_mm"] = num(p.miss_mm);
    j["residual_px"] = p.residual_px;
    j["range_mm"] = p.range_mm;
    j["chi2"] = num(p.chi2);
    j["dof"] = p.dof;
    j["p_value"] = num(p.p_value);
    j["mismatched"] = p.mismatched;
    points.push_back(j);
  }
  Json lengths = Json::array();
  for (const auto& l : r.lengths) {
    Json j = {{"frame", l.frame}, {"id_a", l.id_a}, {"id_b", l.id_b}, {"ok", l.ok}};
    if (!l.ok) {
      j["why"] = l.why;
    } else {
      j["length_mm"] = num(l.length.length_mm);
      j["sigma_mm"] = num(l.length.sigma_mm);
      j["sigma_percent"] = num(100 * l.length.sigma_mm / l.length.length_mm);
      j["sigma_image_mm"] = num(l.length.sigma_image_mm);
      j["sigma_calibration_mm"] = num(l.length.sigma_calibration_mm);
    }
    lengths.push_back(j);
  }
  return {{"measure",
           {{"frame", "the rig frame: camera 0's camera frame (X right, Y down, Z forward, mm; origin at its "
                      "entrance pupil)"},
            {"sigma_px", r.sigma_px},
            {"sigma_px_from", r.sigma_px_from},
            {"covariance", r.covariance_note},
            {"n_points", r.points.size()},
            {"n_failed", r.n_failed},
            {"n_mismatched", r.n_mismatched},
            {"n_unpaired_skipped", r.n_unpaired},
            {"warnings", r.warnings},
            {"laser_ranges", LaserRangesJson(r.laser_ranges)},
            {"points", points},
            {"lengths", lengths}}}};
}

}  // namespace porthole::measure
