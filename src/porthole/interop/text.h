// Small text helpers of the interop readers (YAML, XML, TOML-like and text formats): one copy.
#pragma once

#include <cctype>
#include <string>
#include <string_view>

namespace porthole::interop {

// `s` without leading and trailing spaces, tabs and line ends.
inline std::string Trim(std::string_view s) {
  const auto a = s.find_first_not_of(" \t\r\n");
  if (a == std::string_view::npos) return "";
  return std::string(s.substr(a, s.find_last_not_of(" \t\r\n") - a + 1));
}

// `s` without one pair of matching surrounding quotes ("…" or '…').
inline std::string Unquote(std::string_view s) {
  if (s.size() >= 2 && (s.front() == '"' || s.front() == '\'') && s.back() == s.front()) {
    return std::string(s.substr(1, s.size() - 2));
  }
  return std::string(s);
}

// `s` in ASCII lower case.
inline std::string Lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

}  // namespace porthole::interop
