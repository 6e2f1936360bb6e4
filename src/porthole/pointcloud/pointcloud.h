// Point clouds: reading scans and target lists, writing points with an optional per-point scalar.
//
// Contract: coordinates are millimetres in whatever frame the file uses (usually the scanner's);
// a cloud is a 3×N matrix, one point per column. Readers stream the file (one line or one fixed
// block at a time) and throw InvalidInput whose field is the file path and whose rule names the
// 1-based line (text formats) or the 0-based byte offset (binary formats) where reading failed.
// Every coordinate must be finite; a file with no points is an error.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>

namespace porthole::pointcloud {

enum class Format {
  kAuto,  // from the extension (case-insensitive): .ply, .xyz/.csv/.txt/.pts, .obj, .stl
  kPly,   // PLY: ascii, binary_little_endian or binary_big_endian; vertex x/y/z of any scalar type
  kXyz,   // text table: x y z [more columns ignored], separated by spaces, tabs or commas
  kObj,   // Wavefront OBJ: `v x y z [w | r g b]` lines; every other line is ignored
  kStl,   // STL, ascii or binary: the vertices of the facets
};

struct ReadOptions {
  Format format = Format::kAuto;  // kAuto: decide by extension (explicit formats skip the check)
  bool deduplicate_stl = true;    // STL repeats each shared vertex once per facet; keep one copy
                                  // (bit-identical coordinates) so vertices are not over-weighted
};

struct PointCloud {
  Eigen::Matrix3Xd points;  // mm, one point per column
  std::string source;       // file the points came from (for messages)
  int64_t size() const { return points.cols(); }
};

// Reads the points of `path`. Throws InvalidInput(path, "line L: ..." / "byte B: ...") on
// malformed input, InvalidInput(path, "unknown format ...") for an unrecognised extension.
PointCloud ReadPointCloud(const std::filesystem::path& path, const ReadOptions& options = {});

// Format implied by the extension of `path`; throws InvalidInput(path, ...) when unknown.
Format FormatFromExtension(const std::filesystem::path& path);

struct WriteOptions {
  Format format = Format::kAuto;         // kAuto: by extension; only kPly and kXyz can be written
  bool binary = true;                    // PLY only: binary_little_endian (true) or ascii (false)
  std::string scalar_name = "residual";  // PLY property / XYZ column name of the scalar, if any
  int text_decimals = 6;                 // digits after the point in text output (1e-6 mm)
};

// Writes points (3×N, mm) and, when `scalar` is non-null, one value per point (length N) as an
// extra double property/column. Uses WriteFileAtomically: the file appears whole or not at all.
// Throws InvalidInput("output", ...) for a size mismatch or an unwritable path.
void WritePointCloud(const std::filesystem::path& path, const Eigen::Matrix3Xd& points,
                     const Eigen::VectorXd* scalar = nullptr, const WriteOptions& options = {});

// The bytes WritePointCloud would write for a PLY file (exposed for tests).
std::string EncodePly(const Eigen::Matrix3Xd& points, const Eigen::VectorXd* scalar, bool binary,
                      std::string_view scalar_name = "residual", int text_decimals = 6);

}  // namespace porthole::pointcloud
