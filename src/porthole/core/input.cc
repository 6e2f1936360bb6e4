#include "porthole/core/input.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <vector>

#include <fmt/format.h>

#include "porthole/core/error.h"

namespace porthole {

std::string ReadInputFile(const std::filesystem::path& path, const std::string& field, std::uintmax_t max_bytes) {
  const int fd = open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK);
  if (fd < 0) throw InvalidInput(field, fmt::format("cannot read '{}': {}", path.string(), std::strerror(errno)));
  struct Closer {
    int fd;
    ~Closer() { close(fd); }
  } closer{fd};
  struct stat st {};
  if (fstat(fd, &st) != 0 || S_ISDIR(st.st_mode)) {
    throw InvalidInput(field, fmt::format("'{}' is a directory, not a file", path.string()));
  }
  if (S_ISREG(st.st_mode) && static_cast<std::uintmax_t>(st.st_size) > max_bytes) {
    throw InvalidInput(field, fmt::format("'{}' is larger than the {} MiB limit for this kind of file",
                                          path.string(), max_bytes >> 20));
  }
  fcntl(fd, F_SETFL, fcntl(fd, F_GETFL) & ~O_NONBLOCK);  // opened non-blocking only so a FIFO cannot hang open()
  std::string out;
  if (S_ISREG(st.st_mode)) out.reserve(static_cast<std::size_t>(st.st_size));
  char buf[1 << 16];
  for (;;) {
    const ssize_t n = read(fd, buf, sizeof buf);
    if (n < 0) {
      if (errno == EINTR) continue;
      throw InvalidInput(field, fmt::format("cannot read '{}': {}", path.string(), std::strerror(errno)));
    }
    if (n == 0) break;
    if (out.size() + static_cast<std::size_t>(n) > max_bytes) {
      throw InvalidInput(field, fmt::format("'{}' is larger than the {} MiB limit for this kind of file",
                                            path.string(), max_bytes >> 20));
    }
    out.append(buf, static_cast<std::size_t>(n));
  }
  return out;
}

std::string JsonMessage(const std::exception& e) {
  std::string m = e.what();
  if (m.rfind("[json.exception.", 0) == 0) {
    const auto close = m.find("] ");
    if (close != std::string::npos) m.erase(0, close + 2);
  }
  return m;
}

namespace {

// Line of byte offset `pos` (1-based) and nesting check without recursion.
std::size_t LineOf(std::string_view text, std::size_t pos) {
  std::size_t line = 1;
  for (std::size_t i = 0; i < pos && i < text.size(); ++i) line += text[i] == '\n';
  return line;
}

// Nesting depth, elements per array or object and values per document, checked by one pass over
// the text before nlohmann builds anything (a 250 MB file of numbers took 5.5 GB parsed).
void CheckDepthAndCounts(std::string_view text, const std::string& field, const std::string& origin) {
  int depth = 0;
  bool in_string = false;
  std::size_t elements[kMaxJsonDepth + 1] = {};  // commas seen at each open level
  bool is_array[kMaxJsonDepth + 1] = {};
  std::size_t values = 1;  // the root
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (in_string) {
      if (c == '\\') ++i;
      else if (c == '"') in_string = false;
    } else if (c == '"') {
      in_string = true;
    } else if (c == '[' || c == '{') {
      if (++depth > kMaxJsonDepth) {
        throw InvalidInput(fmt::format("{}:{}", origin, LineOf(text, i)),
                           fmt::format("JSON nested deeper than {} levels", kMaxJsonDepth));
      }
      elements[depth] = 0;
      is_array[depth] = c == '[';
      values += 1;  // its first element (an upper bound: the container may be empty)
    } else if (c == ']' || c == '}') {
      if (depth > 0) --depth;
    } else if (c == ',' && depth > 0) {
      if (++elements[depth] >= kMaxJsonElements) {
        throw InvalidInput(fmt::format("{}: {}:{}", field, origin, LineOf(text, i)),
                           fmt::format("more than the limit of {} {} in one JSON {}", kMaxJsonElements,
                                       is_array[depth] ? "elements" : "members", is_array[depth] ? "array" : "object"));
      }
      if (++values > kMaxJsonValues) {
        throw InvalidInput(fmt::format("{}: {}:{}", field, origin, LineOf(text, i)),
                           fmt::format("more than the limit of {} values in one JSON document", kMaxJsonValues));
      }
    }
  }
}

template <typename J>
J Parse(std::string_view text, const std::string& field, const std::string& origin) {
  CheckDepthAndCounts(text, field, origin);
  try {
    return J::parse(text);
  } catch (const nlohmann::json::parse_error& e) {
    throw InvalidInput(fmt::format("{}: {}:{}", field, origin, LineOf(text, e.byte == 0 ? 0 : e.byte - 1)),
                       "not valid JSON: " + JsonMessage(e));
  } catch (const nlohmann::json::exception& e) {  // out_of_range: a number such as 1e999
    throw InvalidInput(fmt::format("{}: {}", field, origin), "not valid JSON: " + JsonMessage(e));
  }
}

}  // namespace

nlohmann::json ParseJsonText(std::string_view text, const std::string& field, const std::string& origin) {
  return Parse<nlohmann::json>(text, field, origin);
}
nlohmann::ordered_json ParseOrderedJsonText(std::string_view text, const std::string& field,
                                            const std::string& origin) {
  return Parse<nlohmann::ordered_json>(text, field, origin);
}

std::size_t JsonPathLine(std::string_view text, std::string_view path) {
  struct Frame {
    bool object;
    std::string key;    // object: the current member's key
    long index = -1;    // array: the current element
    bool expect_key = true, pending = true;
  };
  std::vector<Frame> stack;
  std::size_t line = 1, best_line = 1, best_len = 0;
  bool done = false;
  // A value begins at `at_line` with the current path: an exact match ends the scan; an ancestor
  // of `path` is remembered.
  auto value_starts = [&](std::size_t at_line) {
    std::string p;
    for (const Frame& f : stack) {
      if (f.object) p += (p.empty() ? "" : ".") + f.key;
      else p += "[" + std::to_string(f.index) + "]";
    }
    if (p == path) {
      best_line = at_line, done = true;
    } else if (p.size() >= best_len && path.substr(0, p.size()) == p &&
               (p.empty() || path[p.size()] == '.' || path[p.size()] == '[')) {
      best_line = at_line, best_len = p.size();
    }
  };
  value_starts(1);
  for (std::size_t i = 0; i < text.size() && !done; ++i) {
    const char c = text[i];
    if (c == '\n') {
      ++line;
      continue;
    }
    if (c == ' ' || c == '\t' || c == '\r') continue;
    Frame* top = stack.empty() ? nullptr : &stack.back();
    if (top && !top->object && top->pending && c != ']') {  // an array element begins
      ++top->index;
      top->pending = false;
      value_starts(line);
    }
    if (c == '"') {
      const std::size_t start_line = line;
      std::string s;
      for (++i; i < text.size() && text[i] != '"'; ++i) {
        if (text[i] == '\\' && i + 1 < text.size()) {
          s += text[++i];  // escapes kept as their letter: enough to match plain keys
        } else {
          if (text[i] == '\n') ++line;
          s += text[i];
        }
      }
      if (top && top->object && top->expect_key) {
        top->key = s;
        top->expect_key = false;
        value_starts(start_line);
      }
    } else if (c == '{' || c == '[') {
      stack.push_back(Frame{c == '{', "", -1, true, true});
    } else if (c == '}' || c == ']') {
      if (!stack.empty()) stack.pop_back();
    } else if (c == ',' && top) {
      if (top->object) top->expect_key = true;
      else top->pending = true;
    }
  }
  return best_line;
}

namespace detail {

void RethrowWithJsonLine(const InvalidInput& e, std::string_view text, const std::string& field,
                         const std::string& origin) {
  const std::string& f = e.field();
  const std::string rule = std::string(e.what()).substr(f.size() + 2);  // "field: rule"
  std::string path;
  if (f.rfind(field, 0) != 0) throw e;  // not about this document
  if (f.size() > field.size()) {
    if (f[field.size()] != '.' && f[field.size()] != '[') throw e;
    path = f.substr(field.size() + (f[field.size()] == '.' ? 1 : 0));
  }
  // "sensor.width_px: must be …": a key path leading the rule goes one deeper.
  const std::size_t colon = rule.find(": ");
  if (colon != std::string::npos && colon > 0 && rule.find(' ') > colon) {
    const std::string key = rule.substr(0, colon);
    path = path.empty() ? key : key[0] == '[' ? path + key : path + "." + key;
  }
  throw InvalidInput(fmt::format("{}: {}:{}", f, origin, JsonPathLine(text, path)), rule);
}

}  // namespace detail

}  // namespace porthole
