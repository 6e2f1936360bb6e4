// Streaming readers for PLY, XYZ/CSV/TXT, OBJ and STL (see pointcloud.h for the contract).
#include <fmt/core.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstring>
#include <fstream>
#include <optional>
#include <unordered_set>
#include <vector>

#include "porthole/core/error.h"
#include "porthole/pointcloud/pointcloud.h"

namespace porthole::pointcloud {
namespace {

static_assert(std::endian::native == std::endian::little, "readers assume a little-endian host");

[[noreturn]] void FailLine(const std::filesystem::path& path, int64_t line,
                           const std::string& what) {
  throw InvalidInput(path.string(), fmt::format("line {}: {}", line, what));
}
[[noreturn]] void FailByte(const std::filesystem::path& path, int64_t byte,
                           const std::string& what) {
  throw InvalidInput(path.string(), fmt::format("byte {}: {}", byte, what));
}

std::string Quote(std::string_view s) {
  constexpr size_t kMax = 40;
  std::string q = "'";
  q.append(s.substr(0, kMax));
  q.append(s.size() > kMax ? "...'" : "'");
  return q;
}

// Parses a whole token as a double; nullopt when it is not a number. Non-finite values parse
// (so the caller can say "not finite" rather than "not a number").
std::optional<double> ParseNumber(std::string_view tok) {
  if (!tok.empty() && tok.front() == '+') tok.remove_prefix(1);
  if (tok.empty()) return std::nullopt;
  double v = 0;
  const auto [ptr, ec] = std::from_chars(tok.data(), tok.data() + tok.size(), v);
  if (ec != std::errc() || ptr != tok.data() + tok.size()) return std::nullopt;
  return v;
}

std::string_view Trim(std::string_view s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
  return s;
}

// Splits on runs of spaces/tabs. Appends to `out` (cleared first).
void SplitWhitespace(std::string_view s, std::vector<std::string_view>& out) {
  out.clear();
  size_t i = 0;
  while (i < s.size()) {
    while (i < s.size() && std::isspace(static_cast<unsigned char>(s[i]))) ++i;
    const size_t b = i;
    while (i < s.size() && !std::isspace(static_cast<unsigned char>(s[i]))) ++i;
    if (i > b) out.push_back(s.substr(b, i - b));
  }
}

// The longest text line read (docs/robustness.md): a file of one 2 GB "line" fails at 64 KiB.
constexpr std::streamsize kMaxLineChars = 64 * 1024;

// Text lines with 1-based numbering and '\r' stripped; a 1 MiB stream buffer.
class LineReader {
 public:
  LineReader(std::istream& in, const std::filesystem::path& path) : in_(in), path_(path) {}
  bool Next(std::string& line) {
    buffer_.resize(static_cast<size_t>(kMaxLineChars) + 1);  // once: later calls keep its size
    in_.getline(buffer_.data(), kMaxLineChars + 1);
    const std::streamsize got = in_.gcount();
    if (in_.fail() && !in_.eof() && got >= kMaxLineChars) {
      FailLine(path_, line_no_ + 1, fmt::format("line longer than {} characters", kMaxLineChars));
    }
    if (got == 0 && in_.eof()) return false;
    if (in_.fail() && !in_.eof()) return false;  // read error
    in_.clear(in_.rdstate() & std::ios::eofbit);
    // gcount counts the '\n' that getline consumed but did not store.
    line.assign(buffer_.data(), static_cast<size_t>(got) - (in_.eof() ? 0 : 1));
    ++line_no_;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    return true;
  }
  int64_t line_no() const { return line_no_; }

 private:
  std::istream& in_;
  const std::filesystem::path& path_;
  std::vector<char> buffer_;
  int64_t line_no_ = 0;
};

std::ifstream OpenOrThrow(const std::filesystem::path& path, std::vector<char>& buffer) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec))
    throw InvalidInput(path.string(), "file does not exist or is not a regular file");
  std::ifstream in;
  buffer.resize(1 << 20);
  in.rdbuf()->pubsetbuf(buffer.data(), static_cast<std::streamsize>(buffer.size()));
  in.open(path, std::ios::binary);
  if (!in) throw InvalidInput(path.string(), "cannot open for reading");
  return in;
}

// Collects points; checks finiteness.
class PointSink {
 public:
  void Reserve(int64_t n) { xyz_.reserve(static_cast<size_t>(std::max<int64_t>(n, 0)) * 3); }
  bool Add(double x, double y, double z) {
    if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z)) return false;
    xyz_.push_back(x);
    xyz_.push_back(y);
    xyz_.push_back(z);
    return true;
  }
  PointCloud Finish(const std::filesystem::path& path) {
    if (xyz_.empty()) throw InvalidInput(path.string(), "contains no points");
    PointCloud cloud;
    cloud.points = Eigen::Map<const Eigen::Matrix3Xd>(xyz_.data(), 3,
                                                      static_cast<Eigen::Index>(xyz_.size() / 3));
    cloud.source = path.string();
    return cloud;
  }
  std::vector<double>& raw() { return xyz_; }

 private:
  std::vector<double> xyz_;
};

// ---------------------------------------------------------------------------------------------
// XYZ / CSV / TXT

// Parses fields[0..2] as x, y, z and adds the point; `what` names a field in errors ("field 2 is
// not a number"). Fails with the file and line for a non-number or a non-finite coordinate.
void AddPointFromFields(const std::vector<std::string_view>& fields, const char* what,
                        const std::filesystem::path& path, int64_t line_no, PointSink* sink) {
  double v[3];
  for (int k = 0; k < 3; ++k) {
    const auto num = ParseNumber(fields[k]);
    if (!num) FailLine(path, line_no, fmt::format("{} {} is not a number: {}", what, k + 1, Quote(fields[k])));
    v[k] = *num;
  }
  if (!sink->Add(v[0], v[1], v[2])) FailLine(path, line_no, "coordinate is not finite");
}

PointCloud ReadXyz(const std::filesystem::path& path) {
  std::vector<char> buf;
  std::ifstream in = OpenOrThrow(path, buf);
  LineReader lines(in, path);
  PointSink sink;
  std::string line;
  std::vector<std::string_view> fields;
  bool seen_content = false;
  while (lines.Next(line)) {
    const std::string_view t = Trim(line);
    if (t.empty() || t.front() == '#') continue;
    if (t.find(',') != std::string_view::npos) {
      fields.clear();
      size_t b = 0;
      while (true) {
        const size_t e = t.find(',', b);
        fields.push_back(Trim(t.substr(b, e == std::string_view::npos ? e : e - b)));
        if (e == std::string_view::npos) break;
        b = e + 1;
      }
    } else {
      SplitWhitespace(t, fields);
    }
    const bool first = !seen_content;
    seen_content = true;
    if (first && !ParseNumber(fields[0])) continue;  // a header line such as "x,y,z"
    if (fields.size() < 3)
      FailLine(path, lines.line_no(),
               fmt::format("expected at least 3 fields (x y z), found {}", fields.size()));
    AddPointFromFields(fields, "field", path, lines.line_no(), &sink);
  }
  if (in.bad()) throw InvalidInput(path.string(), "read error");
  return sink.Finish(path);
}

// ---------------------------------------------------------------------------------------------
// OBJ

PointCloud ReadObj(const std::filesystem::path& path) {
  std::vector<char> buf;
  std::ifstream in = OpenOrThrow(path, buf);
  LineReader lines(in, path);
  PointSink sink;
  std::string line;
  std::vector<std::string_view> fields;
  while (lines.Next(line)) {
    const std::string_view t = Trim(line);
    if (t.size() < 2 || t[0] != 'v' || !std::isspace(static_cast<unsigned char>(t[1]))) continue;
    SplitWhitespace(t.substr(1), fields);
    if (fields.size() < 3)
      FailLine(path, lines.line_no(),
               fmt::format("'v' line needs 3 coordinates, found {}", fields.size()));
    AddPointFromFields(fields, "coordinate", path, lines.line_no(), &sink);
  }
  if (in.bad()) throw InvalidInput(path.string(), "read error");
  return sink.Finish(path);
}

// ---------------------------------------------------------------------------------------------
// Binary input with a byte offset, for PLY and STL.

class BinaryReader {
 public:
  BinaryReader(std::istream& in, const std::filesystem::path& path, int64_t offset)
      : in_(in), path_(path), offset_(offset) {}
  int64_t offset() const { return offset_; }
  // Reads exactly n bytes or throws "file ends" naming `what` at the current offset.
  void Read(void* dst, size_t n, const std::string& what) {
    in_.read(static_cast<char*>(dst), static_cast<std::streamsize>(n));
    const auto got = in_.gcount();
    if (static_cast<size_t>(got) != n) FailByte(path_, offset_ + got, "file ends inside " + what);
    offset_ += static_cast<int64_t>(n);
  }
  bool AtEnd() { return in_.peek() == std::char_traits<char>::eof(); }

 private:
  std::istream& in_;
  const std::filesystem::path& path_;
  int64_t offset_;
};

// ---------------------------------------------------------------------------------------------
// PLY

enum class PlyType { kInt8, kUint8, kInt16, kUint16, kInt32, kUint32, kFloat32, kFloat64 };

std::optional<PlyType> PlyTypeFromName(std::string_view n) {
  if (n == "char" || n == "int8") return PlyType::kInt8;
  if (n == "uchar" || n == "uint8") return PlyType::kUint8;
  if (n == "short" || n == "int16") return PlyType::kInt16;
  if (n == "ushort" || n == "uint16") return PlyType::kUint16;
  if (n == "int" || n == "int32") return PlyType::kInt32;
  if (n == "uint" || n == "uint32") return PlyType::kUint32;
  if (n == "float" || n == "float32") return PlyType::kFloat32;
  if (n == "double" || n == "float64") return PlyType::kFloat64;
  return std::nullopt;
}

int PlyTypeSize(PlyType t) {
  switch (t) {
    case PlyType::kInt8:
    case PlyType::kUint8:
      return 1;
    case PlyType::kInt16:
    case PlyType::kUint16:
      return 2;
    case PlyType::kInt32:
    case PlyType::kUint32:
    case PlyType::kFloat32:
      return 4;
    case PlyType::kFloat64:
      return 8;
  }
  return 0;
}

// The value of a PLY scalar of type V stored (native byte order) at b, as a double.
template <typename V>
double LoadAs(const unsigned char* b) {
  V v;
  std::memcpy(&v, b, sizeof v);
  return static_cast<double>(v);
}

// Decodes one value of type t from `p` (file byte order given by `swap`).
double DecodePly(const unsigned char* p, PlyType t, bool swap) {
  unsigned char b[8];
  const int n = PlyTypeSize(t);
  if (swap) {
    for (int i = 0; i < n; ++i) b[i] = p[n - 1 - i];
  } else {
    std::memcpy(b, p, static_cast<size_t>(n));
  }
  switch (t) {
    case PlyType::kInt8:
      return LoadAs<int8_t>(b);
    case PlyType::kUint8:
      return LoadAs<uint8_t>(b);
    case PlyType::kInt16:
      return LoadAs<int16_t>(b);
    case PlyType::kUint16:
      return LoadAs<uint16_t>(b);
    case PlyType::kInt32:
      return LoadAs<int32_t>(b);
    case PlyType::kUint32:
      return LoadAs<uint32_t>(b);
    case PlyType::kFloat32:
      return LoadAs<float>(b);
    case PlyType::kFloat64:
      return LoadAs<double>(b);
  }
  return 0;
}

struct PlyProperty {
  std::string name;
  PlyType type = PlyType::kFloat32;  // item type for lists
  bool is_list = false;
  PlyType count_type = PlyType::kUint8;
};

struct PlyElement {
  std::string name;
  int64_t count = 0;
  std::vector<PlyProperty> properties;
};

enum class PlyEncoding { kAscii, kBinaryLittle, kBinaryBig };

struct PlyHeader {
  PlyEncoding encoding = PlyEncoding::kAscii;
  std::vector<PlyElement> elements;
  int vertex_element = -1;
  int xyz[3] = {-1, -1, -1};  // property indices of x, y, z in the vertex element
};

PlyHeader ReadPlyHeader(const std::filesystem::path& path, LineReader& lines) {
  PlyHeader h;
  std::string line;
  std::vector<std::string_view> tok;
  if (!lines.Next(line) || Trim(line) != "ply")
    FailLine(path, 1, "not a PLY file (no 'ply' magic)");
  bool have_format = false;
  while (true) {
    if (!lines.Next(line)) FailLine(path, lines.line_no(), "header ends without 'end_header'");
    SplitWhitespace(line, tok);
    if (tok.empty() || tok[0] == "comment" || tok[0] == "obj_info") continue;
    const int64_t ln = lines.line_no();
    if (tok[0] == "end_header") break;
    if (tok[0] == "format") {
      if (tok.size() != 3) FailLine(path, ln, "expected 'format <encoding> 1.0'");
      if (tok[1] == "ascii")
        h.encoding = PlyEncoding::kAscii;
      else if (tok[1] == "binary_little_endian")
        h.encoding = PlyEncoding::kBinaryLittle;
      else if (tok[1] == "binary_big_endian")
        h.encoding = PlyEncoding::kBinaryBig;
      else
        FailLine(path, ln, "unknown PLY encoding " + Quote(tok[1]));
      have_format = true;
    } else if (tok[0] == "element") {
      if (tok.size() != 3) FailLine(path, ln, "expected 'element <name> <count>'");
      const auto n = ParseNumber(tok[2]);
      if (!n || *n < 0 || *n != std::floor(*n) || *n > 1e12)
        FailLine(path, ln, "element count is not a non-negative integer: " + Quote(tok[2]));
      h.elements.push_back({std::string(tok[1]), static_cast<int64_t>(*n), {}});
    } else if (tok[0] == "property") {
      if (h.elements.empty()) FailLine(path, ln, "'property' before any 'element'");
      PlyProperty p;
      if (tok.size() == 5 && tok[1] == "list") {
        const auto ct = PlyTypeFromName(tok[2]);
        const auto it = PlyTypeFromName(tok[3]);
        if (!ct || !it || *ct == PlyType::kFloat32 || *ct == PlyType::kFloat64)
          FailLine(path, ln, "bad list property types");
        p = {std::string(tok[4]), *it, true, *ct};
      } else if (tok.size() == 3) {
        const auto t = PlyTypeFromName(tok[1]);
        if (!t) FailLine(path, ln, "unknown property type " + Quote(tok[1]));
        p = {std::string(tok[2]), *t, false, PlyType::kUint8};
      } else {
        FailLine(path, ln, "expected 'property <type> <name>' or 'property list <t> <t> <name>'");
      }
      h.elements.back().properties.push_back(p);
    } else {
      FailLine(path, ln, "unknown header keyword " + Quote(tok[0]));
    }
  }
  if (!have_format) FailLine(path, lines.line_no(), "header has no 'format' line");
  for (const PlyElement& el : h.elements) {
    if (el.count > 0 && el.properties.empty())
      FailLine(path, lines.line_no(), "element '" + el.name + "' has items but no properties");
  }
  for (size_t e = 0; e < h.elements.size(); ++e) {
    if (h.elements[e].name != "vertex") continue;
    h.vertex_element = static_cast<int>(e);
    const auto& props = h.elements[e].properties;
    for (size_t i = 0; i < props.size(); ++i) {
      for (int k = 0; k < 3; ++k) {
        if (props[i].name == std::string(1, "xyz"[k]) && !props[i].is_list)
          h.xyz[k] = static_cast<int>(i);
      }
    }
  }
  if (h.vertex_element < 0) FailLine(path, lines.line_no(), "no 'element vertex' in the header");
  if (h.xyz[0] < 0 || h.xyz[1] < 0 || h.xyz[2] < 0)
    FailLine(path, lines.line_no(), "vertex element lacks scalar x, y and z properties");
  return h;
}

void ReadPlyAscii(const std::filesystem::path& path, const PlyHeader& h, LineReader& lines,
                  PointSink& sink) {
  std::string line;
  std::vector<std::string_view> tok;
  for (size_t e = 0; e < h.elements.size(); ++e) {
    const PlyElement& el = h.elements[e];
    const bool is_vertex = static_cast<int>(e) == h.vertex_element;
    for (int64_t item = 0; item < el.count; ++item) {
      do {
        if (!lines.Next(line))
          FailLine(path, lines.line_no() + 1,
                   fmt::format("file ends after {} of {} '{}' items", item, el.count, el.name));
        SplitWhitespace(line, tok);
      } while (tok.empty());
      const int64_t ln = lines.line_no();
      size_t t = 0;
      double xyz[3] = {0, 0, 0};
      for (size_t pi = 0; pi < el.properties.size(); ++pi) {
        const PlyProperty& p = el.properties[pi];
        int64_t n_values = 1;
        if (p.is_list) {
          if (t >= tok.size()) FailLine(path, ln, "too few values for '" + el.name + "'");
          const auto c = ParseNumber(tok[t++]);
          if (!c || *c < 0 || *c != std::floor(*c))
            FailLine(path, ln, "list count is not a non-negative integer");
          // Before the conversion: a count of 1e20 or inf does not fit int64_t (undefined; g++ made
          // it INT64_MIN, an empty list, and the line was accepted).
          if (*c > static_cast<double>(tok.size() - t))
            FailLine(path, ln,
                     fmt::format("list count {} is more than the {} values left on the line", tok[t - 1],
                                 tok.size() - t));
          n_values = static_cast<int64_t>(*c);
        }
        for (int64_t v = 0; v < n_values; ++v) {
          if (t >= tok.size())
            FailLine(path, ln,
                     fmt::format("too few values for '{}' (property '{}')", el.name, p.name));
          const auto num = ParseNumber(tok[t]);
          if (!num) FailLine(path, ln, "not a number: " + Quote(tok[t]));
          ++t;
          if (is_vertex && !p.is_list) {
            for (int k = 0; k < 3; ++k)
              if (static_cast<int>(pi) == h.xyz[k]) xyz[k] = *num;
          }
        }
      }
      if (t != tok.size())
        FailLine(
            path, ln,
            fmt::format("{} values where the header declares {} for '{}'", tok.size(), t, el.name));
      if (is_vertex && !sink.Add(xyz[0], xyz[1], xyz[2]))
        FailLine(path, ln, "coordinate is not finite");
    }
  }
  while (lines.Next(line)) {
    if (!Trim(line).empty())
      FailLine(path, lines.line_no(), "data after the last element (header counts too small?)");
  }
}

void ReadPlyBinary(const std::filesystem::path& path, const PlyHeader& h, BinaryReader& in,
                   PointSink& sink) {
  const bool swap = h.encoding == PlyEncoding::kBinaryBig;
  std::vector<unsigned char> row;
  for (size_t e = 0; e < h.elements.size(); ++e) {
    const PlyElement& el = h.elements[e];
    const bool is_vertex = static_cast<int>(e) == h.vertex_element;
    const bool fixed = std::none_of(el.properties.begin(), el.properties.end(),
                                    [](const PlyProperty& p) { return p.is_list; });
    std::vector<int> offsets;  // byte offset of each scalar property within a fixed-size row
    int row_size = 0;
    for (const auto& p : el.properties) {
      offsets.push_back(row_size);
      row_size += p.is_list ? 0 : PlyTypeSize(p.type);
    }
    if (is_vertex) sink.Reserve(el.count);
    for (int64_t item = 0; item < el.count; ++item) {
      const int64_t start = in.offset();
      const std::string what = fmt::format("'{}' item {} of {}", el.name, item, el.count);
      if (fixed) {
        row.resize(static_cast<size_t>(row_size));
        in.Read(row.data(), row.size(), what);
        if (is_vertex) {
          double v[3];
          for (int k = 0; k < 3; ++k) {
            const auto& p = el.properties[static_cast<size_t>(h.xyz[k])];
            v[k] = DecodePly(row.data() + offsets[static_cast<size_t>(h.xyz[k])], p.type, swap);
          }
          if (!sink.Add(v[0], v[1], v[2])) FailByte(path, start, "vertex coordinate is not finite");
        }
        continue;
      }
      double v[3] = {0, 0, 0};
      unsigned char b[8];
      for (size_t pi = 0; pi < el.properties.size(); ++pi) {
        const PlyProperty& p = el.properties[pi];
        if (p.is_list) {
          in.Read(b, static_cast<size_t>(PlyTypeSize(p.count_type)), what);
          const double c = DecodePly(b, p.count_type, swap);
          if (c < 0) FailByte(path, in.offset(), "negative list count");
          for (int64_t i = 0; i < static_cast<int64_t>(c); ++i)
            in.Read(b, static_cast<size_t>(PlyTypeSize(p.type)), what);
        } else {
          in.Read(b, static_cast<size_t>(PlyTypeSize(p.type)), what);
          for (int k = 0; k < 3; ++k)
            if (static_cast<int>(pi) == h.xyz[k]) v[k] = DecodePly(b, p.type, swap);
        }
      }
      if (is_vertex && !sink.Add(v[0], v[1], v[2]))
        FailByte(path, start, "vertex coordinate is not finite");
    }
  }
  if (!in.AtEnd())
    FailByte(path, in.offset(), "data after the last element (header counts too small?)");
}

// Binary element counts come from the header: before reading, skipping or reserving anything they
// must fit in the bytes after the header, or a 126-byte file could ask for 10^12 items (bad_alloc
// from the reservation, or hours of skipping). An item takes at least its scalars and list counts.
// (ASCII needs no check: each item takes a line, and reading stops at the end of the file.)
void CheckPlyCounts(const std::filesystem::path& path, const PlyHeader& h, int64_t data_start, int64_t file_size) {
  if (h.encoding == PlyEncoding::kAscii) return;
  long double need = 0;
  for (const PlyElement& el : h.elements) {
    int64_t item = 0;
    for (const auto& p : el.properties) item += PlyTypeSize(p.is_list ? p.count_type : p.type);
    need += static_cast<long double>(el.count) * static_cast<long double>(item);
    if (need > static_cast<long double>(file_size - data_start)) {
      FailByte(path, file_size,
               fmt::format("file ends inside the '{}' items: the header declares {}, more than the {} bytes "
                           "after the header can hold", el.name, el.count, file_size - data_start));
    }
  }
}

PointCloud ReadPly(const std::filesystem::path& path) {
  std::vector<char> buf;
  std::ifstream in = OpenOrThrow(path, buf);
  LineReader lines(in, path);
  const PlyHeader h = ReadPlyHeader(path, lines);
  if (h.encoding != PlyEncoding::kAscii) {
    CheckPlyCounts(path, h, static_cast<int64_t>(in.tellg()), static_cast<int64_t>(std::filesystem::file_size(path)));
  }
  PointSink sink;
  if (h.encoding == PlyEncoding::kAscii) {
    ReadPlyAscii(path, h, lines, sink);
  } else {
    BinaryReader bin(in, path, static_cast<int64_t>(in.tellg()));
    ReadPlyBinary(path, h, bin, sink);
  }
  return sink.Finish(path);
}

// ---------------------------------------------------------------------------------------------
// STL

struct BitsHash {
  size_t operator()(const std::array<uint64_t, 3>& a) const {
    uint64_t h = 1469598103934665603ull;
    for (uint64_t v : a) h = (h ^ v) * 1099511628211ull ^ (v >> 29);
    return static_cast<size_t>(h);
  }
};

class StlSink {
 public:
  explicit StlSink(bool dedupe) : dedupe_(dedupe) {}
  bool Add(PointSink& sink, double x, double y, double z) {
    if (dedupe_) {
      // +0.0 and -0.0 are the same vertex.
      const std::array<uint64_t, 3> key = {std::bit_cast<uint64_t>(x + 0.0),
                                           std::bit_cast<uint64_t>(y + 0.0),
                                           std::bit_cast<uint64_t>(z + 0.0)};
      if (!seen_.insert(key).second)
        return std::isfinite(x) && std::isfinite(y) && std::isfinite(z);
    }
    return sink.Add(x, y, z);
  }

 private:
  bool dedupe_;
  std::unordered_set<std::array<uint64_t, 3>, BitsHash> seen_;
};

PointCloud ReadStlAscii(const std::filesystem::path& path, std::ifstream& in, bool dedupe) {
  LineReader lines(in, path);
  PointSink sink;
  StlSink stl(dedupe);
  std::string line;
  std::vector<std::string_view> tok;
  int vertices_in_facet = -1;  // -1: outside a facet
  while (lines.Next(line)) {
    SplitWhitespace(line, tok);
    if (tok.empty()) continue;
    const int64_t ln = lines.line_no();
    const std::string_view k = tok[0];
    if (k == "solid" || k == "endsolid" || k == "outer" || k == "endloop") continue;
    if (k == "facet") {
      if (vertices_in_facet >= 0) FailLine(path, ln, "'facet' inside a facet");
      vertices_in_facet = 0;
    } else if (k == "endfacet") {
      if (vertices_in_facet != 3)
        FailLine(path, ln,
                 fmt::format("facet has {} vertices, expected 3", std::max(vertices_in_facet, 0)));
      vertices_in_facet = -1;
    } else if (k == "vertex") {
      if (vertices_in_facet < 0) FailLine(path, ln, "'vertex' outside a facet");
      if (tok.size() != 4) FailLine(path, ln, "expected 'vertex x y z'");
      double v[3];
      for (int i = 0; i < 3; ++i) {
        const auto num = ParseNumber(tok[static_cast<size_t>(i) + 1]);
        if (!num) FailLine(path, ln, "not a number: " + Quote(tok[static_cast<size_t>(i) + 1]));
        v[i] = *num;
      }
      if (!stl.Add(sink, v[0], v[1], v[2])) FailLine(path, ln, "coordinate is not finite");
      ++vertices_in_facet;
    } else {
      FailLine(path, ln, "unexpected STL keyword " + Quote(k));
    }
  }
  if (vertices_in_facet >= 0) FailLine(path, lines.line_no(), "file ends inside a facet");
  return sink.Finish(path);
}

PointCloud ReadStl(const std::filesystem::path& path, bool dedupe) {
  std::vector<char> buf;
  std::ifstream in = OpenOrThrow(path, buf);
  const auto size = static_cast<int64_t>(std::filesystem::file_size(path));
  char head[84] = {};
  in.read(head, 84);
  const auto got = in.gcount();
  uint32_t n_facets = 0;
  if (got == 84) std::memcpy(&n_facets, head + 80, 4);
  const bool binary_size_matches = got == 84 && size == 84 + 50 * static_cast<int64_t>(n_facets);
  if (!binary_size_matches && got >= 5 && std::string_view(head, 5) == "solid") {
    in.clear();
    in.seekg(0);
    return ReadStlAscii(path, in, dedupe);
  }
  if (got < 84) FailByte(path, got, "file ends inside the 84-byte binary STL header");
  BinaryReader bin(in, path, 84);
  PointSink sink;
  StlSink stl(dedupe);
  sink.Reserve(std::min<int64_t>(n_facets, (size - 84) / 50 + 1) * 3);
  unsigned char facet[50];
  for (uint32_t f = 0; f < n_facets; ++f) {
    const int64_t start = bin.offset();
    bin.Read(facet, 50, fmt::format("facet {} of {}", f, n_facets));
    for (int v = 0; v < 3; ++v) {
      float c[3];
      std::memcpy(c, facet + 12 + 12 * v, 12);
      if (!stl.Add(sink, c[0], c[1], c[2]))
        FailByte(path, start + 12 + 12 * v, "vertex coordinate is not finite");
    }
  }
  if (!bin.AtEnd())
    FailByte(path, bin.offset(),
             fmt::format("data after the {} facets the header announces", n_facets));
  return sink.Finish(path);
}

}  // namespace

Format FormatFromExtension(const std::filesystem::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (ext == ".ply") return Format::kPly;
  if (ext == ".xyz" || ext == ".csv" || ext == ".txt" || ext == ".pts") return Format::kXyz;
  if (ext == ".obj") return Format::kObj;
  if (ext == ".stl") return Format::kStl;
  throw InvalidInput(path.string(), "unknown point-cloud format '" + ext +
                                        "' (expected .ply, .xyz, .csv, .txt, .pts, .obj or .stl)");
}

PointCloud ReadPointCloud(const std::filesystem::path& path, const ReadOptions& options) {
  const Format f = options.format == Format::kAuto ? FormatFromExtension(path) : options.format;
  switch (f) {
    case Format::kPly:
      return ReadPly(path);
    case Format::kXyz:
      return ReadXyz(path);
    case Format::kObj:
      return ReadObj(path);
    case Format::kStl:
      return ReadStl(path, options.deduplicate_stl);
    case Format::kAuto:
      break;
  }
  throw InternalError("ReadPointCloud: unresolved format");
}

}  // namespace porthole::pointcloud
