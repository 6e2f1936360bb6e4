// Error kinds shared by every module (see docs/architecture.md, "three kinds of failure"):
//  - InvalidInput: bad input or options. Names the field and the rule it breaks; the CLI prints
//    the message on one line and exits with code 2.
//  - InternalError: a broken invariant inside porthole (a bug). Thrown by PORTHOLE_CHECK.
// Expected numerical outcomes (a ray misses the dome, total internal reflection, no convergence)
// are not errors: they are returned as a status or std::optional.
#pragma once

#include <cmath>
#include <stdexcept>
#include <string>

namespace porthole {

// `s` on one line: control characters and bytes that are not UTF-8 shown escaped (\x..), cut to
// `max_chars` (with "..." appended).
inline std::string OneLineMessage(const std::string& s, std::size_t max_chars = 500) {
  static const char* kHex = "0123456789abcdef";
  std::string out;
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (out.size() >= max_chars) {
      out += "...";
      break;
    }
    const char c = s[i];
    const auto u = static_cast<unsigned char>(c);
    // Length of a valid UTF-8 sequence starting here (0: not one; no overlong or surrogate check).
    std::size_t n = u < 0x80 ? 1 : (u >> 5) == 6 ? 2 : (u >> 4) == 14 ? 3 : (u >> 3) == 30 ? 4 : 0;
    for (std::size_t k = 1; k < n; ++k) {
      if (i + k >= s.size() || (static_cast<unsigned char>(s[i + k]) >> 6) != 2) n = 0;
    }
    if (c == '\n') out += "\\n";
    else if (c == '\r') out += "\\r";
    else if (c == '\t') out += ' ';
    else if (u < 0x20 || u == 0x7f || n == 0) out += std::string("\\x") + kHex[u >> 4] + kHex[u & 15];
    else {
      out.append(s, i, n);
      i += n - 1;
    }
  }
  return out;
}

// `s` without nlohmann::json's "[json.exception.<kind>.<id>] " tags.
inline std::string WithoutJsonTag(std::string s) {
  for (std::size_t p = s.find("[json.exception."); p != std::string::npos; p = s.find("[json.exception.", p)) {
    const std::size_t end = s.find("] ", p);
    if (end == std::string::npos) break;
    s.erase(p, end + 2 - p);
  }
  return s;
}

class InvalidInput : public std::invalid_argument {
 public:
  // field: the name the user knows the value by (a CLI flag, a TOML key); rule: what was expected.
  // The message is kept to one line of bounded length whatever the input holds: control characters
  // are shown escaped (\n, \x1b) and each part is cut at 500 characters (a 100 kB key, a file name
  // with a newline).
  // A library's message passed on as the rule loses its internal tag ("[json.exception.parse_error.101] ").
  InvalidInput(const std::string& field, const std::string& rule)
      : std::invalid_argument(OneLineMessage(field) + ": " + OneLineMessage(WithoutJsonTag(rule))), field_(field) {}
  const std::string& field() const { return field_; }

 private:
  std::string field_;
};

class InternalError : public std::logic_error {
 public:
  using std::logic_error::logic_error;
};

// Throws InvalidInput unless v is finite. Returns v so it can wrap an initialiser.
inline double RequireFinite(const std::string& field, double v) {
  if (!std::isfinite(v)) throw InvalidInput(field, "must be a finite number");
  return v;
}
inline double RequirePositive(const std::string& field, double v) {
  RequireFinite(field, v);
  if (!(v > 0)) throw InvalidInput(field, "must be > 0");
  return v;
}
inline double RequireNonNegative(const std::string& field, double v) {
  RequireFinite(field, v);
  if (!(v >= 0)) throw InvalidInput(field, "must be >= 0");
  return v;
}

}  // namespace porthole

#define PORTHOLE_CHECK(cond)                                                               \
  do {                                                                                     \
    if (!(cond))                                                                           \
      throw ::porthole::InternalError(std::string(__FILE__) + ":" + std::to_string(__LINE__) + \
                                      ": check failed: " #cond);                           \
  } while (0)
