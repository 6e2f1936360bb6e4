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

MeasureResult Measure(const Rig& rig, const std::vector<ImagePoint>& points, const MeasureOptions& options) {
  MeasureResult res;
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
  for (const auto& [key, cams] : by_point) {
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
    }
    all_obs.push_back(std::move(obs));
    index[key] = static_cast<int>(res.points.size());
    res.points.push_back(std::move(m));
  }
  std::vector<Point> tri = TriangulateMany(rig, all_obs, to, options.num_threads);
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
        l.length = MeasureLength(rig, pa, pb);
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
            {"points", points},
            {"lengths", lengths}}}};
}

}  // namespace porthole::measure
