// VIAME's stereo calibration .npz (rig format viame-npz): a zip of float64 .npy arrays
// cameraMatrixL/R, distCoeffsL/R, R, T, as VIAME's tools/calibrate_cameras.py --npz writes them
// (VIAME 05ee7881) and camtrawl's StereoCalibration.from_npzfile reads them, with porthole's
// T_unit and imageSizeL/R; the .npy layout of numpy/lib/format.py (version 1.0 header) and the zip
// through libzip, each member ≤ 1 MiB, at most 64 (docs/interop.md, "Rig files").
#include <fmt/format.h>
#include <zip.h>

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <memory>

#include "porthole/core/error.h"
#include "porthole/interop/pyliteral.h"
#include "porthole/interop/rig_internal.h"

namespace porthole::interop::detail {
namespace {

using camera::Camera;
using camera::CameraModelId;

using Json = nlohmann::json;

constexpr std::size_t kMaxNpzMembers = 64;
constexpr std::size_t kMaxNpyBytes = 1u << 20;

std::string Le16(unsigned v) { return {static_cast<char>(v & 0xff), static_cast<char>((v >> 8) & 0xff)}; }

RigFile ReadViameNpz(const std::string& bytes, const RigReadOptions& o, const std::string& field) {
  const auto members = ReadZip(bytes, field);
  const auto get = [&](const std::string& key) -> NpyArray {
    for (const auto& [name, data] : members) {
      if (name == key + ".npy") return ParseNpy(data, field + ": " + key);
    }
    throw InvalidInput(field + ": " + key, "missing (VIAME's npz holds cameraMatrixL, distCoeffsL, cameraMatrixR, distCoeffsR, R, T)");
  };
  const auto numbers = [&](const std::string& key, std::size_t count) {
    NpyArray a = get(key);
    if (a.is_text) throw InvalidInput(field + ": " + key, "must be numbers");
    if (count > 0 && a.data.size() != count) {
      throw InvalidInput(field + ": " + key, fmt::format("must hold {} numbers, not {}", count, a.data.size()));
    }
    return a.data;
  };
  const auto km = [&](const std::string& key) { return CheckCameraMatrix(numbers(key, 9), field + ": " + key); };
  const auto kl = km("cameraMatrixL"), kr = km("cameraMatrixR");
  const auto dl = CheckOpenCVDistortion(numbers("distCoeffsL", 0), field + ": distCoeffsL");
  const auto dr = CheckOpenCVDistortion(numbers("distCoeffsR", 0), field + ": distCoeffsR");
  const Eigen::Matrix3d r = Rotation(numbers("R", 9), field + ": R");
  const auto t = numbers("T", 3);
  // The image size: VIAME's npz has none (porthole writes imageSizeL/R), else the option.
  const auto size = [&](const std::string& key) -> std::pair<int, int> {
    for (const auto& [name, unused] : members) {
      if (name == key + ".npy") {
        const auto v = numbers(key, 2);
        return {PixelsValue(v[0], field + ": " + key), PixelsValue(v[1], field + ": " + key)};
      }
    }
    if (!o.image_size) {
      throw InvalidInput(field + ": " + key, "missing: VIAME's npz does not hold the image size: give it (width x height, px)");
    }
    return *o.image_size;
  };
  auto [wl, hl] = size("imageSizeL");
  auto [wr, hr] = size("imageSizeR");
  std::optional<YNode> unit;
  for (const auto& [name, data] : members) {
    if (name == "T_unit.npy") {
      const NpyArray a = ParseNpy(data, field + ": T_unit");
      if (!a.is_text) throw InvalidInput(field + ": T_unit", "must be text (mm, cm or m)");
      unit = Scalar(a.text);
    }
  }
  RigFile tmp;
  const double mm = TUnitMm(unit ? &*unit : nullptr, o, field, &tmp);
  RigFile rig = PairRig(PixelOpenCV(wl, hl, o.pixel_pitch_mm, kl, dl), PixelOpenCV(wr, hr, o.pixel_pitch_mm, kr, dr), r,
                        Eigen::Vector3d(t[0], t[1], t[2]) * mm, "left", "right");
  rig.length_unit_note = tmp.length_unit_note;
  rig.format = RigFormat::kViameNpz;
  return rig;
}

std::string WriteViameNpz(const RigFile& rig, const std::string& field, std::vector<RigWriteCamera>* info) {
  const PairCameras p = OpenCVPair(rig, RigFormat::kViameNpz, field);
  const auto [r, t] = Relative(rig.cameras[0], rig.cameras[1]);
  const int n1 = std::max(OpenCVCount(p.first.cam), 5), n2 = std::max(OpenCVCount(p.second.cam), 5);  // as cv2.stereoCalibrate
  const Eigen::Matrix3d rt = r.transpose();
  const auto arr = [](std::vector<int> shape, std::vector<double> data) {
    NpyArray a;
    a.shape = std::move(shape);
    a.data = std::move(data);
    return NpyBytes(a);
  };
  NpyArray unit;
  unit.is_text = true;
  unit.text = "mm";
  const auto& s1 = p.first.cam.sensor;
  const auto& s2 = p.second.cam.sensor;
  std::vector<std::pair<std::string, std::string>> m = {
      {"cameraMatrixL.npy", arr({3, 3}, KMatrix(p.first.cam))},
      {"distCoeffsL.npy", arr({1, n1}, Coefficients(p.first.cam, n1))},
      {"cameraMatrixR.npy", arr({3, 3}, KMatrix(p.second.cam))},
      {"distCoeffsR.npy", arr({1, n2}, Coefficients(p.second.cam, n2))},
      {"R.npy", arr({3, 3}, std::vector<double>(rt.data(), rt.data() + 9))},
      {"T.npy", arr({3, 1}, {t(0), t(1), t(2)})},
      {"imageSizeL.npy", arr({2}, {double(s1.width_px), double(s1.height_px)})},
      {"imageSizeR.npy", arr({2}, {double(s2.width_px), double(s2.height_px)})},
      {"T_unit.npy", NpyBytes(unit)}};
  info->push_back({rig.cameras[0].name, fmt::format("{} coefficients", n1), p.first.exact, p.first.fit});
  info->push_back({rig.cameras[1].name, fmt::format("{} coefficients", n2), p.second.exact, p.second.fit});
  return ZipStored(m, field);
}

}  // namespace

RigFile ReadViameNpzFile(const std::vector<std::string>& contents, const std::vector<std::string>& /*names*/,
                         RigFormat /*format*/, const RigReadOptions& options, const std::string& field) {
  return ReadViameNpz(contents[0], options, field);
}

RigFiles WriteViameNpzFile(const RigFile& rig, RigFormat /*format*/, const std::string& field,
                           std::vector<RigWriteCamera>* info) {
  return {{"", WriteViameNpz(rig, field, info)}};
}

}  // namespace porthole::interop::detail

namespace porthole::interop {

using detail::Le16;
using detail::kMaxNpyBytes;
using detail::kMaxNpzMembers;
using Json = nlohmann::json;

// ---- .npy (numpy's format description, numpy/lib/format.py: version 1.0 header) ----

std::string NpyBytes(const NpyArray& a) {
  std::string shape = "(";
  for (std::size_t i = 0; i < a.shape.size(); ++i) shape += fmt::format("{}, ", a.shape[i]);
  if (a.shape.size() > 1) shape.resize(shape.size() - 2);
  if (a.shape.size() == 1) shape.resize(shape.size() - 1);
  shape += ")";
  std::string data;
  std::string descr = "<f8";
  if (a.is_text) {
    descr = fmt::format("<U{}", std::max<std::size_t>(a.text.size(), 1));
    for (unsigned char ch : a.text) data += std::string{static_cast<char>(ch), 0, 0, 0};  // ASCII as UTF-32LE
    if (a.text.empty()) data = std::string(4, '\0');
    shape = "()";
  } else {
    data.resize(a.data.size() * 8);
    std::memcpy(data.data(), a.data.data(), data.size());
  }
  std::string header = fmt::format("{{'descr': '{}', 'fortran_order': False, 'shape': {}, }}", descr, shape);
  while ((10 + header.size() + 1) % 64 != 0) header += ' ';
  header += '\n';
  return std::string("\x93NUMPY\x01\x00", 8) + Le16(static_cast<unsigned>(header.size())) + header + data;
}

NpyArray ParseNpy(std::string_view b, const std::string& field) {
  if (b.size() < 10 || b.substr(0, 6) != std::string_view("\x93NUMPY", 6)) throw InvalidInput(field, "not a .npy array");
  const int major = static_cast<unsigned char>(b[6]);
  std::size_t hlen = 0, at = 0;
  if (major == 1) {
    hlen = static_cast<unsigned char>(b[8]) | (static_cast<unsigned char>(b[9]) << 8);
    at = 10;
  } else if (major == 2 || major == 3) {
    if (b.size() < 12) throw InvalidInput(field, "a truncated .npy header");
    for (int i = 3; i >= 0; --i) hlen = (hlen << 8) | static_cast<unsigned char>(b[8 + i]);
    at = 12;
  } else {
    throw InvalidInput(field, fmt::format(".npy version {} is not read (1, 2, 3)", major));
  }
  if (hlen > 4096 || at + hlen > b.size()) throw InvalidInput(field, "a truncated .npy header");
  const Json h = ParsePythonLiteral(b.substr(at, hlen), field);
  if (!h.is_object() || !h.contains("descr") || !h["descr"].is_string() || !h.contains("shape") || !h["shape"].is_array()) {
    throw InvalidInput(field, "a .npy header without descr and shape");
  }
  NpyArray a;
  std::size_t count = 1;
  if (h["shape"].size() > 8) throw InvalidInput(field, "a .npy shape of more than 8 dimensions");
  for (const auto& s : h["shape"]) {
    if (!s.is_number_integer() || s.get<long long>() < 0 || s.get<long long>() > 4096) throw InvalidInput(field, "a bad .npy shape");
    a.shape.push_back(s.get<int>());
    count *= static_cast<std::size_t>(s.get<int>());
    if (count > 4096) throw InvalidInput(field, "more than 4096 values");
  }
  const bool fortran = h.contains("fortran_order") && h["fortran_order"].is_boolean() && h["fortran_order"].get<bool>();
  const std::string descr = h["descr"].get<std::string>();
  const std::string_view data = b.substr(at + hlen);
  if (descr.size() > 2 && descr[1] == 'U' && (descr[0] == '<' || descr[0] == '|')) {
    const std::string digits = descr.substr(2);
    if (digits.empty() || digits.size() > 3 || digits.find_first_not_of("0123456789") != std::string::npos) {
      throw InvalidInput(field, "a bad text dtype '" + descr.substr(0, 20) + "'");
    }
    const std::size_t n = std::stoul(digits);
    if (count != 1 || n > 64 || data.size() < 4 * n) throw InvalidInput(field, "a text array must be one string of at most 64 characters");
    a.is_text = true;
    for (std::size_t i = 0; i < n; ++i) {
      const unsigned char ch = static_cast<unsigned char>(data[4 * i]);
      if (ch == 0) break;
      if (ch > 127 || data[4 * i + 1] || data[4 * i + 2] || data[4 * i + 3]) throw InvalidInput(field, "not ASCII text");
      a.text += static_cast<char>(ch);
    }
    return a;
  }
  const bool f8 = descr == "<f8", f4 = descr == "<f4";
  if (!f8 && !f4) throw InvalidInput(field, fmt::format("dtype '{}' is not read (float64 '<f8' or float32 '<f4')", descr.substr(0, 20)));
  const std::size_t item = f8 ? 8 : 4;
  if (data.size() != count * item) throw InvalidInput(field, fmt::format("holds {} bytes, not the {} its shape needs", data.size(), count * item));
  std::vector<double> v(count);
  for (std::size_t i = 0; i < count; ++i) {
    if (f8) {
      std::memcpy(&v[i], data.data() + 8 * i, 8);
    } else {
      float x;
      std::memcpy(&x, data.data() + 4 * i, 4);
      v[i] = x;
    }
    if (!std::isfinite(v[i])) throw InvalidInput(field, "holds a value that is not finite");
  }
  if (fortran && a.shape.size() == 2) {  // column-major → row-major
    const int rows = a.shape[0], cols = a.shape[1];
    std::vector<double> c(count);
    for (int r = 0; r < rows; ++r) {
      for (int q = 0; q < cols; ++q) c[r * cols + q] = v[q * rows + r];
    }
    v = std::move(c);
  } else if (fortran && a.shape.size() > 2) {
    throw InvalidInput(field, "a Fortran-ordered array of more than 2 dimensions");
  }
  a.data = std::move(v);
  return a;
}

// ---- zip through libzip ----

std::string ZipStored(const std::vector<std::pair<std::string, std::string>>& members, const std::string& field) {
  zip_error_t err;
  zip_error_init(&err);
  zip_source_t* src = zip_source_buffer_create(nullptr, 0, 0, &err);
  if (src == nullptr) throw InternalError("libzip: " + std::string(zip_error_strerror(&err)));
  zip_source_keep(src);
  zip_t* za = zip_open_from_source(src, ZIP_TRUNCATE, &err);
  if (za == nullptr) {
    zip_source_free(src);
    throw InternalError("libzip: " + std::string(zip_error_strerror(&err)));
  }
  for (const auto& [name, data] : members) {
    zip_source_t* s = zip_source_buffer(za, data.data(), data.size(), 0);
    const zip_int64_t idx = s ? zip_file_add(za, name.c_str(), s, ZIP_FL_ENC_UTF_8) : -1;
    if (idx < 0) {
      if (s) zip_source_free(s);
      zip_discard(za);
      zip_source_free(src);
      throw InvalidInput(field, "libzip: cannot add " + name);
    }
    zip_set_file_compression(za, idx, ZIP_CM_STORE, 0);
    zip_file_set_mtime(za, idx, 315619200, 0);  // 1980-01-02: the same bytes every time
  }
  if (zip_close(za) < 0) {
    const std::string e = zip_strerror(za);
    zip_discard(za);
    zip_source_free(src);
    throw InternalError("libzip: " + e);
  }
  std::string out;
  if (zip_source_open(src) == 0) {
    zip_source_seek(src, 0, SEEK_END);
    const zip_int64_t size = zip_source_tell(src);
    zip_source_seek(src, 0, SEEK_SET);
    out.resize(static_cast<std::size_t>(std::max<zip_int64_t>(size, 0)));
    const zip_int64_t got = zip_source_read(src, out.data(), out.size());
    zip_source_close(src);
    if (got != size) out.clear();
  }
  zip_source_free(src);
  if (out.empty()) throw InternalError("libzip: the archive could not be read back");
  return out;
}

std::vector<std::pair<std::string, std::string>> ReadZip(std::string_view bytes, const std::string& field) {
  zip_error_t err;
  zip_error_init(&err);
  zip_source_t* src = zip_source_buffer_create(bytes.data(), bytes.size(), 0, &err);
  if (src == nullptr) throw InternalError("libzip: " + std::string(zip_error_strerror(&err)));
  zip_t* za = zip_open_from_source(src, ZIP_RDONLY | ZIP_CHECKCONS, &err);
  if (za == nullptr) {
    zip_source_free(src);
    throw InvalidInput(field, "not a zip archive (an .npz is one): " + std::string(zip_error_strerror(&err)));
  }
  std::unique_ptr<zip_t, void (*)(zip_t*)> guard(za, [](zip_t* z) { zip_discard(z); });
  const zip_int64_t n = zip_get_num_entries(za, 0);
  if (n < 0 || static_cast<std::size_t>(n) > kMaxNpzMembers) {
    throw InvalidInput(field, fmt::format("more than {} members: not a calibration npz", kMaxNpzMembers));
  }
  std::vector<std::pair<std::string, std::string>> out;
  for (zip_int64_t i = 0; i < n; ++i) {
    zip_stat_t st;
    zip_stat_init(&st);
    if (zip_stat_index(za, i, 0, &st) != 0 || !(st.valid & ZIP_STAT_SIZE) || !(st.valid & ZIP_STAT_NAME)) {
      throw InvalidInput(field, "a zip member cannot be read");
    }
    if (st.size > kMaxNpyBytes) throw InvalidInput(field, fmt::format("member {} is larger than {} bytes", st.name, kMaxNpyBytes));
    zip_file_t* zf = zip_fopen_index(za, i, 0);
    if (zf == nullptr) throw InvalidInput(field, fmt::format("member {} cannot be opened: {}", st.name, zip_strerror(za)));
    std::string data(st.size, '\0');
    const zip_int64_t got = st.size ? zip_fread(zf, data.data(), st.size) : 0;
    zip_fclose(zf);
    if (got != static_cast<zip_int64_t>(st.size)) throw InvalidInput(field, fmt::format("member {} is truncated or corrupt", st.name));
    out.emplace_back(st.name, std::move(data));
  }
  return out;
}

}  // namespace porthole::interop
