// PLY and XYZ writers (see pointcloud.h).
#include <fmt/format.h>

#include <cstring>

#include "porthole/core/atomic_file.h"
#include "porthole/core/error.h"
#include "porthole/pointcloud/pointcloud.h"

namespace porthole::pointcloud {
namespace {

void CheckScalar(const Eigen::Matrix3Xd& points, const Eigen::VectorXd* scalar) {
  if (scalar != nullptr && scalar->size() != points.cols())
    throw InvalidInput(
        "output", fmt::format("{} scalar values for {} points", scalar->size(), points.cols()));
}

void CheckName(std::string_view name) {
  if (name.empty() || name.find_first_of(" \t\r\n,") != std::string_view::npos)
    throw InvalidInput("scalar_name", "must be one word without spaces or commas");
}

// Appends one text row per point: "x y z [scalar]".
void AppendRows(fmt::memory_buffer& out, const Eigen::Matrix3Xd& points,
                const Eigen::VectorXd* scalar, int decimals) {
  for (Eigen::Index i = 0; i < points.cols(); ++i) {
    fmt::format_to(std::back_inserter(out), "{:.{}f} {:.{}f} {:.{}f}", points(0, i), decimals,
                   points(1, i), decimals, points(2, i), decimals);
    if (scalar != nullptr)
      fmt::format_to(std::back_inserter(out), " {:.{}f}", (*scalar)(i), decimals);
    out.push_back('\n');
  }
}

std::string EncodeXyz(const Eigen::Matrix3Xd& points, const Eigen::VectorXd* scalar,
                      std::string_view scalar_name, int decimals) {
  fmt::memory_buffer out;
  if (scalar != nullptr) fmt::format_to(std::back_inserter(out), "x y z {}\n", scalar_name);
  AppendRows(out, points, scalar, decimals);
  return fmt::to_string(out);
}

}  // namespace

std::string EncodePly(const Eigen::Matrix3Xd& points, const Eigen::VectorXd* scalar, bool binary,
                      std::string_view scalar_name, int text_decimals) {
  CheckScalar(points, scalar);
  if (scalar != nullptr) CheckName(scalar_name);
  fmt::memory_buffer out;
  fmt::format_to(std::back_inserter(out),
                 "ply\nformat {} 1.0\ncomment porthole point cloud, units mm\n"
                 "element vertex {}\nproperty double x\nproperty double y\nproperty double z\n",
                 binary ? "binary_little_endian" : "ascii", points.cols());
  if (scalar != nullptr)
    fmt::format_to(std::back_inserter(out), "property double {}\n", scalar_name);
  fmt::format_to(std::back_inserter(out), "end_header\n");
  if (binary) {
    const int per = scalar != nullptr ? 4 : 3;
    const size_t header = out.size();
    out.resize(header + sizeof(double) * static_cast<size_t>(per * points.cols()));
    char* p = out.data() + header;
    for (Eigen::Index i = 0; i < points.cols(); ++i) {
      double v[4] = {points(0, i), points(1, i), points(2, i), scalar ? (*scalar)(i) : 0.0};
      std::memcpy(p, v, sizeof(double) * static_cast<size_t>(per));  // host is little endian
      p += sizeof(double) * static_cast<size_t>(per);
    }
    return std::string(out.data(), out.size());
  }
  AppendRows(out, points, scalar, text_decimals);
  return fmt::to_string(out);
}

void WritePointCloud(const std::filesystem::path& path, const Eigen::Matrix3Xd& points,
                     const Eigen::VectorXd* scalar, const WriteOptions& options) {
  CheckScalar(points, scalar);
  Format f = options.format;
  if (f == Format::kAuto) {
    try {
      f = FormatFromExtension(path);
    } catch (const InvalidInput&) {
      throw InvalidInput("output", "cannot tell the format of " + path.string() +
                                       " (use .ply, .xyz, .csv, .txt or .pts)");
    }
  }
  if (options.text_decimals < 0 || options.text_decimals > 17)
    throw InvalidInput("text_decimals", "must be in 0..17");
  std::string bytes;
  if (f == Format::kPly) {
    bytes = EncodePly(points, scalar, options.binary, options.scalar_name, options.text_decimals);
  } else if (f == Format::kXyz) {
    if (scalar != nullptr) CheckName(options.scalar_name);
    bytes = EncodeXyz(points, scalar, options.scalar_name, options.text_decimals);
  } else {
    throw InvalidInput("output", "only PLY and XYZ/CSV/TXT can be written: " + path.string());
  }
  WriteFileAtomically(path, bytes, "output");
}

}  // namespace porthole::pointcloud
