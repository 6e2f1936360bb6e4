// Reading untrusted input files (docs/robustness.md): every file a user gives porthole may come from
// someone else, so reads are capped in size, JSON is parsed with a nesting limit, and every failure
// is an InvalidInput naming the file (and line) on one line.
#pragma once

#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>

namespace porthole {

// Size caps (bytes) for whole-file reads; point clouds and images are streamed and checked apart.
inline constexpr std::uintmax_t kMaxTextFileBytes = 16u << 20;    // TOML, YAML: 16 MiB
inline constexpr std::uintmax_t kMaxJsonFileBytes = 256u << 20;   // calibration, detections: 256 MiB
inline constexpr int kMaxJsonDepth = 64;                          // nesting of [ and {

// The whole content of `path`, at most `max_bytes` (a device such as /dev/zero or a FIFO stops there
// with an error, not after gigabytes). Throws InvalidInput(field, ...) if it cannot be read, is a
// directory, or is larger.
std::string ReadInputFile(const std::filesystem::path& path, const std::string& field,
                          std::uintmax_t max_bytes = kMaxTextFileBytes);

// Parses JSON text from `origin` (a file name, for messages). Throws InvalidInput(field, "origin:line:
// what") on a syntax error or on nesting deeper than kMaxJsonDepth, never a raw nlohmann message.
nlohmann::json ParseJsonText(std::string_view text, const std::string& field, const std::string& origin);
nlohmann::ordered_json ParseOrderedJsonText(std::string_view text, const std::string& field,
                                            const std::string& origin);

// The message of a nlohmann::json exception without its "[json.exception.type_error.302] " prefix.
std::string JsonMessage(const std::exception& e);

}  // namespace porthole
