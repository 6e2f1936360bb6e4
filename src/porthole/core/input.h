// Reading untrusted input files (docs/robustness.md): every file a user gives porthole may come from
// someone else, so reads are capped in size, JSON is parsed with a nesting limit, and every failure
// is an InvalidInput naming the file (and line) on one line.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>

#include "porthole/core/error.h"

namespace porthole {

// Size caps (bytes) for whole-file reads; point clouds and images are streamed and checked apart.
inline constexpr std::uintmax_t kMaxTextFileBytes = 16u << 20;    // TOML, YAML: 16 MiB
inline constexpr std::uintmax_t kMaxJsonFileBytes = 256u << 20;   // detection sets: 256 MiB
inline constexpr int kMaxJsonDepth = 64;                          // nesting of [ and {
inline constexpr std::uintmax_t kMaxCalibrationFileBytes = 32u << 20;  // a calibration, any format: 32 MiB

// Count limits (docs/robustness.md, "Limits"): memory and time follow what a file holds, not its
// bytes (a parsed JSON number takes 16 bytes, an object member about 100). Each error names its limit.
inline constexpr std::size_t kMaxJsonElements = 1'000'000;   // elements of one array or members of one object
inline constexpr std::size_t kMaxJsonValues = 8'000'000;     // values in one JSON document
inline constexpr std::size_t kMaxPointsPerImage = 100'000;   // detections of one image
inline constexpr std::size_t kMaxImagesPerSet = 10'000;      // images of a detection set, `detect --images`
inline constexpr std::size_t kMaxPointsPerSet = 1'000'000;   // detections of a whole set (a calibration's points)
inline constexpr std::size_t kMaxTargetPoints = 20'000;      // points of a rendered target

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

// The 1-based line where the value at `path` begins in JSON `text` (for an object member: the line of
// its key). Paths are keys joined by '.', array elements by [i]: "camera.K1", "images[2].points_px",
// "" = the whole document. When `path` is absent, the line of its deepest present ancestor (a
// missing key points at the object that lacks it). nlohmann::json keeps no positions for values, so
// this is a small scan of its own (strings, nesting, commas), run only when an error is reported.
std::size_t JsonPathLine(std::string_view text, std::string_view path);

// Runs f(), which reads JSON parsed from `text` (read from file `origin`) and reports bad values as
// InvalidInput(field + path, rule) — path as above after `field`, or leading the rule ("sensor.
// width_px: must be …"). Such an error is rethrown with "origin:line" of that path after its field:
// "--air-calibration.camera.K1: paper-air.json:12: must be a number". nlohmann's type errors are
// reported the same way at `field`.
template <typename F>
auto WithJsonLines(std::string_view text, const std::string& field, const std::string& origin, F&& f)
    -> decltype(f());

// The message of a nlohmann::json exception without its "[json.exception.type_error.302] " prefix.
std::string JsonMessage(const std::exception& e);

namespace detail {
[[noreturn]] void RethrowWithJsonLine(const InvalidInput& e, std::string_view text, const std::string& field,
                                      const std::string& origin);
}  // namespace detail

template <typename F>
auto WithJsonLines(std::string_view text, const std::string& field, const std::string& origin, F&& f)
    -> decltype(f()) {
  try {
    return f();
  } catch (const InvalidInput& e) {
    detail::RethrowWithJsonLine(e, text, field, origin);
  } catch (const nlohmann::json::exception& e) {
    detail::RethrowWithJsonLine(InvalidInput(field, JsonMessage(e)), text, field, origin);
  }
}

}  // namespace porthole
