// The bounded YAML reader of the rig formats (rig_internal.h): what OpenCV's FileStorage, ROS's
// camera_info and Kalibr's camchain write — block mappings and sequences, flow sequences of scalars
// ([a, b], nested), scalars, comments, tags (!!opencv-matrix) and directives skipped — line by line,
// nesting ≤ 16, ≤ 100 000 lines (docs/interop.md, "Rig files"); and an <opencv_storage> XML
// document as the same tree.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>

#include "porthole/core/error.h"
#include "porthole/interop/rig_internal.h"
#include "porthole/interop/text.h"

namespace porthole::interop::detail {
namespace {

constexpr std::size_t kMaxYamlLines = 100000;
constexpr int kMaxYamlDepth = 16;

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

}  // namespace

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

namespace {

double ToNumber(const std::string& s, const std::string& where) {
  char* end = nullptr;
  const std::string t = Trim(s);
  const double v = std::strtod(t.c_str(), &end);
  if (t.empty() || end != t.c_str() + t.size() || !std::isfinite(v)) {
    throw InvalidInput(where, "'" + t.substr(0, 40) + "' is not a finite number");
  }
  return v;
}

}  // namespace

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

namespace {

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

}  // namespace

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

}  // namespace porthole::interop::detail
