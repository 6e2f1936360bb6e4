#include "porthole/interop/pyliteral.h"

#include <cctype>
#include <cerrno>
#include <charconv>
#include <cstdlib>

#include "porthole/core/error.h"

namespace porthole::interop {
namespace {

constexpr std::size_t kMaxBytes = std::size_t(256) << 20;
constexpr int kMaxDepth = 64;

class Parser {
 public:
  Parser(std::string_view s, const std::string& field) : s_(s), field_(field) {}

  nlohmann::json Document() {
    nlohmann::json v = Value(0);
    Skip();
    if (pos_ != s_.size()) Fail("unexpected text after the literal");
    return v;
  }

 private:
  [[noreturn]] void Fail(const std::string& what) const {
    int line = 1, col = 1;
    for (std::size_t i = 0; i < pos_ && i < s_.size(); ++i) {
      if (s_[i] == '\n') {
        ++line;
        col = 1;
      } else {
        ++col;
      }
    }
    throw InvalidInput(field_, "line " + std::to_string(line) + ", column " + std::to_string(col) +
                                   ": " + what);
  }

  void Skip() {
    while (pos_ < s_.size()) {
      const char c = s_[pos_];
      if (c == '#') {
        while (pos_ < s_.size() && s_[pos_] != '\n') ++pos_;
      } else if (std::isspace(static_cast<unsigned char>(c))) {
        ++pos_;
      } else {
        break;
      }
    }
  }

  bool Eat(char c) {
    Skip();
    if (pos_ < s_.size() && s_[pos_] == c) {
      ++pos_;
      return true;
    }
    return false;
  }

  nlohmann::json Value(int depth) {
    if (depth > kMaxDepth) Fail("nested deeper than " + std::to_string(kMaxDepth) + " levels");
    Skip();
    if (pos_ >= s_.size()) Fail("unexpected end of file");
    const char c = s_[pos_];
    if (c == '{') return Dict(depth);
    if (c == '[') return Sequence(depth, ']');
    if (c == '(') return Sequence(depth, ')');
    if (c == '\'' || c == '"') return String();
    if ((c == 'b' || c == 'B') && pos_ + 1 < s_.size() && (s_[pos_ + 1] == '\'' || s_[pos_ + 1] == '"')) {
      ++pos_;
      return String();
    }
    if (c == '-' || c == '+' || c == '.' || std::isdigit(static_cast<unsigned char>(c))) return Number();
    for (const auto& [word, value] : {std::pair<std::string_view, nlohmann::json>{"True", true},
                                      {"False", false}, {"None", nullptr}}) {
      if (s_.substr(pos_, word.size()) == word &&
          (pos_ + word.size() == s_.size() || !std::isalnum(static_cast<unsigned char>(s_[pos_ + word.size()])))) {
        pos_ += word.size();
        return value;
      }
    }
    Fail("not a Python literal (only dicts, lists, tuples, strings, numbers, True, False, None)");
  }

  nlohmann::json Dict(int depth) {
    ++pos_;  // '{'
    nlohmann::json obj = nlohmann::json::object();
    while (!Eat('}')) {
      Skip();
      const nlohmann::json key = Value(depth + 1);
      if (!key.is_string()) Fail("dict keys must be strings");
      if (!Eat(':')) Fail("expected ':' after the key '" + key.get<std::string>() + "'");
      obj[key.get<std::string>()] = Value(depth + 1);
      if (!Eat(',')) {
        if (!Eat('}')) Fail("expected ',' or '}'");
        break;
      }
    }
    return obj;
  }

  nlohmann::json Sequence(int depth, char close) {
    ++pos_;  // '[' or '('
    nlohmann::json arr = nlohmann::json::array();
    while (!Eat(close)) {
      arr.push_back(Value(depth + 1));
      if (!Eat(',')) {
        if (!Eat(close)) Fail(std::string("expected ',' or '") + close + "'");
        break;
      }
    }
    return arr;
  }

  nlohmann::json String() {
    const char q = s_[pos_];
    const bool triple = s_.substr(pos_, 3) == std::string(3, q);
    pos_ += triple ? 3 : 1;
    std::string out;
    while (true) {
      if (pos_ >= s_.size()) Fail("unterminated string");
      const char c = s_[pos_];
      if (c == q && (!triple || s_.substr(pos_, 3) == std::string(3, q))) {
        pos_ += triple ? 3 : 1;
        return out;
      }
      if (c == '\n' && !triple) Fail("newline inside a string");
      if (c == '\\') {
        if (pos_ + 1 >= s_.size()) Fail("unterminated string");
        const char e = s_[pos_ + 1];
        switch (e) {
          case 'n': out += '\n'; break;
          case 't': out += '\t'; break;
          case 'r': out += '\r'; break;
          case '\\': case '\'': case '"': out += e; break;
          case '\n': break;  // line continuation
          default: out += '\\'; out += e; break;
        }
        pos_ += 2;
        continue;
      }
      out += c;
      ++pos_;
    }
  }

  nlohmann::json Number() {
    const std::size_t start = pos_;
    if (s_[pos_] == '+' || s_[pos_] == '-') ++pos_;
    bool is_float = false;
    while (pos_ < s_.size()) {
      const char c = s_[pos_];
      if (std::isdigit(static_cast<unsigned char>(c)) || c == '_') {
        ++pos_;
      } else if (c == '.' || c == 'e' || c == 'E') {
        is_float = true;
        ++pos_;
        if ((c == 'e' || c == 'E') && pos_ < s_.size() && (s_[pos_] == '+' || s_[pos_] == '-')) ++pos_;
      } else {
        break;
      }
    }
    std::string text;
    for (std::size_t i = start; i < pos_; ++i) {
      if (s_[i] != '_') text += s_[i];
    }
    if (!text.empty() && text[0] == '+') text.erase(0, 1);
    char* end = nullptr;
    if (!is_float) {
      errno = 0;
      const long long v = std::strtoll(text.c_str(), &end, 10);
      if (end != text.c_str() + text.size() || text.empty() || text == "-") Fail("bad number '" + text + "'");
      // strtoll saturates: 99999999999999999999 would be read as 9.22e18.
      if (errno == ERANGE) Fail("the integer '" + text.substr(0, 40) + "' does not fit in 64 bits");
      return v;
    }
    const double v = std::strtod(text.c_str(), &end);
    if (end != text.c_str() + text.size()) Fail("bad number '" + text + "'");
    return v;
  }

  std::string_view s_;
  const std::string& field_;
  std::size_t pos_ = 0;
};

}  // namespace

nlohmann::json ParsePythonLiteral(std::string_view text, const std::string& field) {
  if (text.size() > kMaxBytes) throw InvalidInput(field, "larger than 256 MB");
  return Parser(text, field).Document();
}

}  // namespace porthole::interop
