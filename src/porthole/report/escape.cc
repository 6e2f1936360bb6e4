// Escaping of every text that reaches a gnuplot script or a data file (docs/robustness.md). Names,
// descriptions and sources come from port, camera and lens files that travel between users: they are
// data, and must never become gnuplot commands (gnuplot runs `...` inside double-quoted strings and
// `system` anywhere a command may start).
#include <fmt/format.h>

#include "porthole/report/internal.h"

namespace porthole::report {

std::string OneLine(const std::string& s) {
  std::string out;
  out.reserve(s.size());
  for (char c : s) {
    const auto u = static_cast<unsigned char>(c);
    out += (u < 0x20 || u == 0x7f) ? ' ' : c;
  }
  // A comment ending in a backslash continues on the next line in gnuplot: never end with one.
  while (!out.empty() && out.back() == '\\') out.pop_back();
  return out;
}

std::string GpText(const std::string& s) {
  // Single-quoted: gnuplot does no backslash, backquote or macro processing inside; '' is a quote.
  // Enhanced text markup (^ _ @ & ~ { } \) is escaped with a backslash so it prints as typed.
  std::string out = "'";
  for (char c : OneLine(s)) {
    switch (c) {
      case '\'': out += "''"; break;
      case '^': case '_': case '@': case '&': case '~': case '{': case '}': case '\\':
        out += '\\';
        out += c;
        break;
      default: out += c;
    }
  }
  return out + "'";
}

void CheckGnuplotScript(const std::string& script, const std::string& id) {
  // Walks the script as gnuplot's scanner does: comments, single- and double-quoted strings. A
  // backquote outside a single-quoted string would run a shell command.
  enum { kCode, kSingle, kDouble, kComment } state = kCode;
  for (std::size_t i = 0; i < script.size(); ++i) {
    const char c = script[i];
    switch (state) {
      case kCode:
        if (c == '`') throw InternalError(fmt::format("figure {}: command substitution in its script", id));
        if (c == '#') state = kComment;
        if (c == '\'') state = kSingle;
        if (c == '"') state = kDouble;
        break;
      case kSingle:
        if (c == '\n') throw InternalError(fmt::format("figure {}: unterminated string in its script", id));
        if (c == '\'') {
          if (i + 1 < script.size() && script[i + 1] == '\'') ++i;
          else state = kCode;
        }
        break;
      case kDouble:
        if (c == '`') throw InternalError(fmt::format("figure {}: command substitution in its script", id));
        if (c == '\n') throw InternalError(fmt::format("figure {}: unterminated string in its script", id));
        if (c == '\\') ++i;
        else if (c == '"') state = kCode;
        break;
      case kComment:
        if (c == '\n' && (i == 0 || script[i - 1] != '\\')) state = kCode;
        break;
    }
  }
}

}  // namespace porthole::report
