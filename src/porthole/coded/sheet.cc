#include "porthole/coded/sheet.h"

#include <Eigen/Geometry>

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <map>
#include <numbers>
#include <set>
#include <sstream>

#include "porthole/core/error.h"

namespace porthole::coded {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kStripMm = 16;       // bottom strip: scale bar and caption
constexpr double kScaleBarMm = 100;   // length of the scale bar
constexpr double kBarHeightMm = 2;

std::string Num(double v) {  // shortest fixed text to 1e-6 mm
  std::string s = fmt::format("{:.6f}", v);
  while (s.back() == '0') s.pop_back();
  if (s.back() == '.') s.pop_back();
  return s == "-0" ? "0" : s;
}

double OuterRadiusMm(const SheetOptions& o) { return Ring(o.profile).outer * o.radius_mm; }
double LabelSizeMm(const SheetOptions& o) { return 0.7 * o.radius_mm; }
// Label centre relative to the dot centre: toward the cell's lower-right corner, clear of the ring.
Eigen::Vector2d LabelOffset(const SheetLayout& l) { return Eigen::Vector2d(0.36, 0.36) * l.pitch_mm; }

std::string Caption(const SheetLayout& l) {
  const auto& o = l.options;
  const int last = l.targets.empty() ? o.first_id : l.targets.back().id;
  return fmt::format("porthole coded targets: {} {}-bit, dot radius {} mm, IDs {}-{}. Print at 100 %: the bar is {} mm.",
                     ProfileName(o.profile), o.bits, Num(o.radius_mm), o.first_id, last, Num(kScaleBarMm));
}

// Cubic Bézier pieces of the arc of radius r about c from angle a to b (y-down sheet frame).
template <class Emit>
void ArcBeziers(const Eigen::Vector2d& c, double r, double a, double b, Emit&& emit) {
  const int n = std::max(1, static_cast<int>(std::ceil(std::abs(b - a) / (kPi / 8) - 1e-9)));
  for (int i = 0; i < n; ++i) {
    const double t0 = a + (b - a) * i / n, t1 = a + (b - a) * (i + 1) / n;
    const double k = 4.0 / 3.0 * std::tan((t1 - t0) / 4);
    const Eigen::Vector2d p0 = c + r * Eigen::Vector2d(std::cos(t0), std::sin(t0));
    const Eigen::Vector2d p3 = c + r * Eigen::Vector2d(std::cos(t1), std::sin(t1));
    emit(p0 + k * r * Eigen::Vector2d(-std::sin(t0), std::cos(t0)),
         p3 - k * r * Eigen::Vector2d(-std::sin(t1), std::cos(t1)), p3);
  }
}

}  // namespace

Eigen::Vector2d PaperSizeMm(const std::string& paper) {
  std::string s = paper;
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  static const std::map<std::string, Eigen::Vector2d> kPapers = {
      {"a5", {148, 210}}, {"a4", {210, 297}}, {"a3", {297, 420}}, {"a2", {420, 594}},
      {"letter", {215.9, 279.4}}, {"legal", {215.9, 355.6}}};
  if (const auto it = kPapers.find(s); it != kPapers.end()) return it->second;
  const auto x = s.find('x');
  if (x != std::string::npos) {
    try {
      std::size_t n1 = 0, n2 = 0;
      const double w = std::stod(s.substr(0, x), &n1), h = std::stod(s.substr(x + 1), &n2);
      if (n1 == x && n2 == s.size() - x - 1 && w >= 50 && h >= 50 && w <= 5000 && h <= 5000) return {w, h};
    } catch (const std::exception&) {
    }
  }
  throw InvalidInput("paper", "expected A5, A4, A3, A2, letter, legal or WxH in mm (50 to 5000 a side), got '" +
                                    paper + "'");
}

SheetLayout LayoutSheet(const SheetOptions& o) {
  ValidateBits(o.bits);
  if (!(o.radius_mm >= 0.5 && o.radius_mm <= 200)) {
    throw InvalidInput("radius_mm", fmt::format("the dot radius must be 0.5 to 200 mm, got {}", o.radius_mm));
  }
  if (!(o.margin_mm >= 0 && o.margin_mm <= 100)) throw InvalidInput("margin_mm", "must be 0 to 100 mm");
  if (o.count < 0) throw InvalidInput("count", "must be >= 0 (0: as many as fit)");
  CodeOfId(o.profile, o.bits, o.first_id, "first_id");
  SheetLayout l;
  l.options = o;
  Eigen::Vector2d size = PaperSizeMm(o.paper);
  if (o.landscape) std::swap(size.x(), size.y());
  l.width_mm = size.x();
  l.height_mm = size.y();
  if (l.width_mm < kScaleBarMm + 2 * o.margin_mm + 10) {
    throw InvalidInput("paper", fmt::format("{} mm wide: the 100 mm scale bar needs {} mm with the margins",
                                              Num(l.width_mm), Num(kScaleBarMm + 2 * o.margin_mm + 10)));
  }
  l.pitch_mm = std::ceil(2 * (OuterRadiusMm(o) + o.radius_mm) * 2) / 2;
  const double avail_w = l.width_mm - 2 * o.margin_mm, avail_h = l.height_mm - 2 * o.margin_mm - kStripMm;
  l.cols = static_cast<int>(std::floor(avail_w / l.pitch_mm));
  l.rows = static_cast<int>(std::floor(avail_h / l.pitch_mm));
  if (l.cols < 1 || l.rows < 1) {
    throw InvalidInput("radius_mm", fmt::format("a target of dot radius {} mm needs {} mm a side: none fits on "
                                                  "the {} x {} mm paper inside the margins",
                                                  Num(o.radius_mm), Num(l.pitch_mm), Num(l.width_mm), Num(l.height_mm)));
  }
  const int available = static_cast<int>(Codes(o.profile, o.bits).size()) - o.first_id + 1;
  const int n = std::min({o.count > 0 ? o.count : l.cols * l.rows, l.cols * l.rows, available});
  if (o.count > l.cols * l.rows) {
    throw InvalidInput("count", fmt::format("{} targets do not fit: the sheet holds {}", o.count, l.cols * l.rows));
  }
  if (o.count > available) {
    throw InvalidInput("count", fmt::format("IDs {} on give only {} targets", o.first_id, available));
  }
  const double x0 = o.margin_mm + (avail_w - l.cols * l.pitch_mm) / 2 + l.pitch_mm / 2;
  const double y0 = o.margin_mm + (avail_h - l.rows * l.pitch_mm) / 2 + l.pitch_mm / 2;
  for (int k = 0; k < n; ++k) {
    l.targets.push_back({o.first_id + k, Eigen::Vector3d(x0 + (k % l.cols) * l.pitch_mm,
                                                         y0 + (k / l.cols) * l.pitch_mm, 0)});
  }
  l.scale_bar_mm = Eigen::Vector2d(o.margin_mm + 5, l.height_mm - o.margin_mm - kStripMm + 4);
  return l;
}

std::vector<std::pair<double, double>> RingArcs(uint32_t code, int bits) {
  auto bit = [&](int i) { return (code >> (bits - 1 - ((i % bits + bits) % bits))) & 1u; };
  std::vector<std::pair<double, double>> arcs;
  int start = 0;  // begin at a 0 so that no run wraps (an admitted code has a 0)
  while (start < bits && bit(start)) ++start;
  for (int i = start; i < start + bits;) {
    if (!bit(i)) {
      ++i;
      continue;
    }
    int j = i;
    while (j < start + bits && bit(j)) ++j;
    arcs.emplace_back(2 * kPi * i / bits, 2 * kPi * j / bits);
    i = j;
  }
  return arcs;
}

std::string SheetSvg(const SheetLayout& l) {
  const auto& o = l.options;
  const std::string ink = o.white_on_black ? "#fff" : "#000";
  std::string s = fmt::format(
      "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
      "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{0}mm\" height=\"{1}mm\" viewBox=\"0 0 {0} {1}\">\n"
      "<title>{2}</title>\n<rect width=\"{0}\" height=\"{1}\" fill=\"#fff\"/>\n",
      Num(l.width_mm), Num(l.height_mm), Caption(l));
  if (o.white_on_black) {
    const double x = l.targets.front().xyz_mm.x() - l.pitch_mm / 2, y = l.targets.front().xyz_mm.y() - l.pitch_mm / 2;
    s += fmt::format("<rect id=\"field\" x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"#000\"/>\n", Num(x),
                     Num(y), Num(l.cols * l.pitch_mm), Num(l.rows * l.pitch_mm));
  }
  const RingRadii ring = Ring(o.profile);
  const double ri = ring.inner * o.radius_mm, ro = ring.outer * o.radius_mm;
  const double font = LabelSizeMm(o);
  for (const auto& t : l.targets) {
    const Eigen::Vector2d c = t.xyz_mm.head<2>();
    s += fmt::format("<g id=\"t{}\" fill=\"{}\">\n<circle cx=\"{}\" cy=\"{}\" r=\"{}\"/>\n", t.id, ink, Num(c.x()),
                     Num(c.y()), Num(o.radius_mm));
    for (const auto& [a, b] : RingArcs(CodeOfId(o.profile, o.bits, t.id), o.bits)) {
      const int large = b - a > kPi ? 1 : 0;
      auto p = [&](double r, double ang) { return fmt::format("{} {}", Num(c.x() + r * std::cos(ang)), Num(c.y() + r * std::sin(ang))); };
      s += fmt::format("<path d=\"M {} A {} {} 0 {} 1 {} L {} A {} {} 0 {} 0 {} Z\"/>\n", p(ro, a), Num(ro), Num(ro),
                       large, p(ro, b), p(ri, b), Num(ri), Num(ri), large, p(ri, a));
    }
    const Eigen::Vector2d lc = c + LabelOffset(l);
    s += fmt::format("<text x=\"{}\" y=\"{}\" font-family=\"Helvetica, Arial, sans-serif\" font-size=\"{}\" "
                     "text-anchor=\"middle\">{}</text>\n</g>\n",
                     Num(lc.x()), Num(lc.y() + 0.35 * font), Num(font), t.id);
  }
  // Scale bar: ten 10 mm blocks, alternately filled, in a 0.2 mm outline; ticks labelled in mm.
  const Eigen::Vector2d b = l.scale_bar_mm;
  s += fmt::format("<g id=\"scale-bar\" font-family=\"Helvetica, Arial, sans-serif\" font-size=\"2.5\">\n"
                   "<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"none\" stroke=\"#000\" stroke-width=\"0.2\"/>\n",
                   Num(b.x()), Num(b.y()), Num(kScaleBarMm), Num(kBarHeightMm));
  for (int i = 0; i < 10; i += 2) {
    s += fmt::format("<rect x=\"{}\" y=\"{}\" width=\"10\" height=\"{}\"/>\n", Num(b.x() + 10 * i), Num(b.y()),
                     Num(kBarHeightMm));
  }
  for (int mm : {0, 50, 100}) {
    s += fmt::format("<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">{}</text>\n", Num(b.x() + mm),
                     Num(b.y() + kBarHeightMm + 3), mm == 100 ? "100 mm" : std::to_string(mm));
  }
  s += fmt::format("</g>\n<text x=\"{}\" y=\"{}\" font-family=\"Helvetica, Arial, sans-serif\" font-size=\"2.5\">{}</text>\n"
                   "</svg>\n",
                   Num(b.x()), Num(b.y() + kBarHeightMm + 8), Caption(l));
  return s;
}

std::string SheetPdf(const SheetLayout& l) {
  const auto& o = l.options;
  constexpr double kPtPerMm = 72 / 25.4;
  std::string c = fmt::format("q {} 0 0 {} 0 {} cm\n", Num(kPtPerMm), Num(-kPtPerMm), Num(l.height_mm * kPtPerMm));
  auto move = [&](const Eigen::Vector2d& p) { c += fmt::format("{} {} m\n", Num(p.x()), Num(p.y())); };
  auto line = [&](const Eigen::Vector2d& p) { c += fmt::format("{} {} l\n", Num(p.x()), Num(p.y())); };
  auto arc = [&](const Eigen::Vector2d& ctr, double r, double a, double b) {
    ArcBeziers(ctr, r, a, b, [&](const Eigen::Vector2d& p1, const Eigen::Vector2d& p2, const Eigen::Vector2d& p3) {
      c += fmt::format("{} {} {} {} {} {} c\n", Num(p1.x()), Num(p1.y()), Num(p2.x()), Num(p2.y()), Num(p3.x()), Num(p3.y()));
    });
  };
  auto polar = [](const Eigen::Vector2d& ctr, double r, double a) { return Eigen::Vector2d(ctr + r * Eigen::Vector2d(std::cos(a), std::sin(a))); };
  // Text at (x, y) (baseline, mm) of `size` mm, upright despite the flipped page matrix.
  auto text = [&](double x, double y, double size, const std::string& t) {
    std::string esc;
    for (char ch : t) {
      if (ch == '(' || ch == ')' || ch == '\\') esc += '\\';
      esc += ch;
    }
    c += fmt::format("BT /F1 {} Tf 1 0 0 -1 {} {} Tm ({}) Tj ET\n", Num(size), Num(x), Num(y), esc);
  };
  const std::string ink = o.white_on_black ? "1 g\n" : "0 g\n";
  if (o.white_on_black) {
    const double x = l.targets.front().xyz_mm.x() - l.pitch_mm / 2, y = l.targets.front().xyz_mm.y() - l.pitch_mm / 2;
    c += fmt::format("0 g {} {} {} {} re f\n", Num(x), Num(y), Num(l.cols * l.pitch_mm), Num(l.rows * l.pitch_mm));
  }
  const RingRadii ring = Ring(o.profile);
  const double ri = ring.inner * o.radius_mm, ro = ring.outer * o.radius_mm, font = LabelSizeMm(o);
  c += ink;
  for (const auto& t : l.targets) {
    const Eigen::Vector2d ctr = t.xyz_mm.head<2>();
    move(polar(ctr, o.radius_mm, 0));
    arc(ctr, o.radius_mm, 0, 2 * kPi);
    c += "h f\n";
    for (const auto& [a, b] : RingArcs(CodeOfId(o.profile, o.bits, t.id), o.bits)) {
      move(polar(ctr, ro, a));
      arc(ctr, ro, a, b);
      line(polar(ctr, ri, b));
      arc(ctr, ri, b, a);
      c += "h f\n";
    }
    // Helvetica digits are all 0.556 em wide: centre the label on its point.
    const std::string id = std::to_string(t.id);
    const Eigen::Vector2d lc = ctr + LabelOffset(l);
    text(lc.x() - 0.278 * font * id.size(), lc.y() + 0.35 * font, font, id);
  }
  const Eigen::Vector2d b = l.scale_bar_mm;
  c += fmt::format("0 g 0.2 w {} {} {} {} re S\n", Num(b.x()), Num(b.y()), Num(kScaleBarMm), Num(kBarHeightMm));
  for (int i = 0; i < 10; i += 2) c += fmt::format("{} {} 10 {} re f\n", Num(b.x() + 10 * i), Num(b.y()), Num(kBarHeightMm));
  for (int mm : {0, 50, 100}) {
    const std::string t = mm == 100 ? "100 mm" : std::to_string(mm);
    text(b.x() + mm - 0.278 * 2.5 * (mm == 0 ? 1 : mm == 50 ? 2 : 3), b.y() + kBarHeightMm + 3, 2.5, t);
  }
  text(b.x(), b.y() + kBarHeightMm + 8, 2.5, Caption(l));
  c += "Q\n";

  std::vector<std::string> objects = {
      "<< /Type /Catalog /Pages 2 0 R >>",
      "<< /Type /Pages /Kids [3 0 R] /Count 1 >>",
      fmt::format("<< /Type /Page /Parent 2 0 R /MediaBox [0 0 {} {}] /Resources << /Font << /F1 4 0 R >> >> "
                  "/Contents 5 0 R >>",
                  Num(l.width_mm * kPtPerMm), Num(l.height_mm * kPtPerMm)),
      "<< /Type /Font /Subtype /Type1 /BaseFont /Helvetica /Encoding /WinAnsiEncoding >>",
      fmt::format("<< /Length {} >>\nstream\n{}endstream", c.size(), c),
      fmt::format("<< /Title ({}) /Producer (porthole target-sheet) >>", Caption(l))};
  std::string pdf = "%PDF-1.4\n%\xe2\xe3\xcf\xd3\n";
  std::vector<std::size_t> offsets;
  for (std::size_t i = 0; i < objects.size(); ++i) {
    offsets.push_back(pdf.size());
    pdf += fmt::format("{} 0 obj\n{}\nendobj\n", i + 1, objects[i]);
  }
  const std::size_t xref = pdf.size();
  pdf += fmt::format("xref\n0 {}\n0000000000 65535 f \n", objects.size() + 1);
  for (std::size_t off : offsets) pdf += fmt::format("{:010d} 00000 n \n", off);
  pdf += fmt::format("trailer\n<< /Size {} /Root 1 0 R /Info 6 0 R >>\nstartxref\n{}\n%%EOF\n", objects.size() + 1, xref);
  return pdf;
}

std::string FieldText(const SheetLayout& l) {
  const auto& o = l.options;
  std::string s = fmt::format(
      "# porthole target field: {} {}-bit coded targets, dot radius {} mm, {} {} sheet ({} x {} mm)\n"
      "# frame: the sheet, origin at the paper's top-left corner, X right, Y down, Z = 0 on the paper; mm\n"
      "# id x_mm y_mm z_mm\n",
      ProfileName(o.profile), o.bits, Num(o.radius_mm), o.paper, o.landscape ? "landscape" : "portrait",
      Num(l.width_mm), Num(l.height_mm));
  for (const auto& t : l.targets) {
    s += fmt::format("{} {:.4f} {:.4f} {:.4f}\n", t.id, t.xyz_mm.x(), t.xyz_mm.y(), t.xyz_mm.z());
  }
  return s;
}

bool FacesMinusZ(const PlacedTarget& t) { return (t.normal + Eigen::Vector3d::UnitZ()).norm() < 1e-12; }

std::pair<Eigen::Vector3d, Eigen::Vector3d> DotAxes(const Eigen::Vector3d& normal) {
  const Eigen::Vector3d z = -normal.normalized();  // the dot's own "Z", away from its printed side
  if ((z - Eigen::Vector3d::UnitZ()).norm() < 1e-12) return {Eigen::Vector3d::UnitX(), Eigen::Vector3d::UnitY()};
  // u: the sheet's X projected into the plane (or Y when X is along the normal), v = z × u.
  Eigen::Vector3d u = Eigen::Vector3d::UnitX() - z.x() * z;
  if (u.norm() < 1e-6) u = Eigen::Vector3d::UnitY() - z.y() * z;
  u.normalize();
  return {u, z.cross(u)};
}

std::vector<PlacedTarget> ParseField(const std::string& text, const std::string& field) {
  std::vector<PlacedTarget> out;
  std::set<int> seen;
  std::istringstream in(text);
  std::string line;
  for (int n = 1; std::getline(in, line); ++n) {
    std::string comment;
    if (const auto h = line.find('#'); h != std::string::npos) comment = line.substr(h + 1), line.erase(h);
    std::replace(line.begin(), line.end(), ',', ' ');
    std::istringstream ls(line);
    std::vector<std::string> words;
    for (std::string w; ls >> w;) words.push_back(w);
    if (words.empty()) continue;
    const std::string where = fmt::format("line {}", n);
    if (words.size() != 4 && words.size() != 7) {
      throw InvalidInput(field, where + ": expected 'id x_mm y_mm z_mm' (or with the normal: 'id x_mm y_mm z_mm nx ny nz')");
    }
    double v[7];
    for (std::size_t i = 0; i < words.size(); ++i) {
      std::size_t used = 0;
      try {
        v[i] = std::stod(words[i], &used);
      } catch (const std::exception&) {
        used = 0;
      }
      if (used != words[i].size() || !std::isfinite(v[i])) throw InvalidInput(field, where + ": '" + words[i] + "' is not a number");
    }
    if (v[0] != std::floor(v[0]) || v[0] < 1 || v[0] > 1e6) throw InvalidInput(field, where + ": the ID must be a whole number >= 1");
    const int id = static_cast<int>(v[0]);
    if (!seen.insert(id).second) throw InvalidInput(field, fmt::format("{}: ID {} appears twice", where, id));
    PlacedTarget t{id, Eigen::Vector3d(v[1], v[2], v[3])};
    if (words.size() == 7) {
      const Eigen::Vector3d n(v[4], v[5], v[6]);
      if (!(n.norm() > 1e-9)) throw InvalidInput(field, where + ": the normal (nx ny nz) must not be zero");
      t.normal = n.normalized();
    }
    // "# [sigma_mm sx sy sz] control": a control point, its σ (none given: exact).
    std::istringstream cs(comment);
    std::vector<std::string> notes;
    for (std::string w; cs >> w;) notes.push_back(w);
    if (std::find(notes.begin(), notes.end(), "control") != notes.end()) {
      Eigen::Vector3d sigma = Eigen::Vector3d::Zero();
      const auto at = std::find(notes.begin(), notes.end(), "sigma_mm");
      if (at != notes.end()) {
        if (notes.end() - at < 4) throw InvalidInput(field, where + ": 'sigma_mm' takes three numbers (sx sy sz)");
        for (int k = 0; k < 3; ++k) {
          std::size_t used = 0;
          try {
            sigma(k) = std::stod(at[1 + k], &used);
          } catch (const std::exception&) {
            used = 0;
          }
          if (used != at[1 + k].size() || !std::isfinite(sigma(k)) || sigma(k) < 0) {
            throw InvalidInput(field, where + ": a control point's sigma_mm must be three numbers >= 0");
          }
        }
      }
      t.control_sigma_mm = sigma;
    }
    out.push_back(t);
  }
  if (out.empty()) throw InvalidInput(field, "holds no targets");
  return out;
}

}  // namespace porthole::coded
