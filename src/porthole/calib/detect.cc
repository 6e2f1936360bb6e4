#include "porthole/calib/detect.h"

#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cmath>
#include <cerrno>
#include <condition_variable>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <mutex>
#include <thread>
#include <opencv2/aruco/charuco.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/utils/logger.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <png.h>

#include "porthole/coded/detect.h"
#include "porthole/core/error.h"
#include "porthole/core/input.h"

namespace porthole::calib {
namespace fs = std::filesystem;
namespace {

uint32_t Be32(const unsigned char* p) { return uint32_t(p[0]) << 24 | uint32_t(p[1]) << 16 | uint32_t(p[2]) << 8 | p[3]; }
uint16_t Be16(const unsigned char* p) { return static_cast<uint16_t>(p[0] << 8 | p[1]); }
uint32_t Le32(const unsigned char* p) { return uint32_t(p[3]) << 24 | uint32_t(p[2]) << 16 | uint32_t(p[1]) << 8 | p[0]; }
uint16_t Le16(const unsigned char* p) { return static_cast<uint16_t>(p[1] << 8 | p[0]); }

// PNG through libpng itself rather than cv::imread: OpenCV gives libpng its default handlers,
// which print "libpng warning: …" and "libpng error: …" on stderr. Here warnings are collected
// (the first is kept, on one line, for the image's progress line) and an error is the skip
// reason. libpng's own limits are set to the image's: the size check happens in the decoder's
// header read too. The transforms are OpenCV's for IMREAD_GRAYSCALE (grfmt_png.cpp), so the
// pixels are the same: palette expanded, alpha stripped, 16 bits cut to 8, RGB to grey with
// weights 0.299, 0.587.
struct PngRead {
  std::string warning;  // the first libpng warning
  std::string error;    // why it could not be decoded
};

void PngWarning(png_structp png, png_const_charp msg) {
  auto* r = static_cast<PngRead*>(png_get_error_ptr(png));
  if (r->warning.empty()) r->warning = msg ? msg : "";
}
[[noreturn]] void PngError(png_structp png, png_const_charp msg) {
  auto* r = static_cast<PngRead*>(png_get_error_ptr(png));
  r->error = msg ? msg : "libpng error";
  png_longjmp(png, 1);
}

// Decodes the PNG file `f` (at its start) into 8-bit grey; empty on error (read->error says why).
cv::Mat DecodePngGray(std::FILE* f, long width, long height, PngRead* read) {
  png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, read, PngError, PngWarning);
  if (png == nullptr) {
    read->error = "libpng could not start";
    return {};
  }
  png_infop info = png_create_info_struct(png);
  // What changes after setjmp lives on the heap: automatic variables modified between setjmp and
  // longjmp are indeterminate after it.
  struct Out {
    cv::Mat img;
    std::vector<png_bytep> rows;
  };
  const auto out = std::make_unique<Out>();
  if (info == nullptr || setjmp(png_jmpbuf(png))) {
    png_destroy_read_struct(&png, info ? &info : nullptr, nullptr);
    return {};
  }
  if (width > 0 && height > 0) png_set_user_limits(png, static_cast<png_uint_32>(width), static_cast<png_uint_32>(height));
  png_set_chunk_malloc_max(png, 64u << 20);  // a text or ICC chunk cannot ask for more
  png_init_io(png, f);
  png_read_info(png, info);
  const png_uint_32 w = png_get_image_width(png, info), h = png_get_image_height(png, info);
  const int bit_depth = png_get_bit_depth(png, info), color_type = png_get_color_type(png, info);
  if (bit_depth == 16) png_set_strip_16(png);
  png_set_strip_alpha(png);
  if (color_type == PNG_COLOR_TYPE_PALETTE) png_set_palette_to_rgb(png);
  if ((color_type & PNG_COLOR_MASK_COLOR) == 0 && bit_depth < 8) png_set_expand_gray_1_2_4_to_8(png);
  if (color_type & PNG_COLOR_MASK_COLOR) png_set_rgb_to_gray(png, 1, 0.299, 0.587);
  png_set_interlace_handling(png);
  png_read_update_info(png, info);
  if (png_get_rowbytes(png, info) != w) png_error(png, "unexpected row size after conversion to grey");
  out->img.create(static_cast<int>(h), static_cast<int>(w), CV_8UC1);
  out->rows.resize(h);
  for (png_uint_32 y = 0; y < h; ++y) out->rows[y] = out->img.ptr<png_byte>(static_cast<int>(y));
  png_read_image(png, out->rows.data());
  png_read_end(png, nullptr);
  png_destroy_read_struct(&png, &info, nullptr);
  return out->img;
}

// Refines X-junction corners on the full-resolution image: cv::cornerSubPix on a Gaussian-smoothed
// patch around each corner. Smoothing (sigma 2 px) makes the gradient directions exact enough that a
// rotated, oblique board comes out within 0.01 px of the truth on rendered images, where
// cornerSubPix on raw pixels and findChessboardCornersSB each leave up to 0.07 px (detect_test.cc).
// A point-symmetric X-junction keeps its centre under a symmetric blur, so the blur adds no bias.
// `half` is the window's half-size and `sigma` the blur's (px): the window must see the junction's
// point-symmetric neighbourhood alone. A corner that moves by more than max_move_px keeps its start.
void RefineXCorners(const cv::Mat& gray, int half, double sigma, double max_move_px, std::vector<cv::Point2f>* pts) {
  const int margin = half + static_cast<int>(std::ceil(4 * sigma)) + 4;
  const cv::Rect image(0, 0, gray.cols, gray.rows);
  for (auto& p : *pts) {
    const cv::Rect roi = cv::Rect(static_cast<int>(std::lround(p.x)) - margin, static_cast<int>(std::lround(p.y)) - margin,
                                  2 * margin + 1, 2 * margin + 1) & image;
    if (roi.width < 2 * half + 5 || roi.height < 2 * half + 5) continue;  // at the image border: keep it
    cv::Mat patch;
    gray(roi).convertTo(patch, CV_32F);
    cv::GaussianBlur(patch, patch, cv::Size(0, 0), sigma);
    std::vector<cv::Point2f> one = {p - cv::Point2f(static_cast<float>(roi.x), static_cast<float>(roi.y))};
    cv::cornerSubPix(patch, one, cv::Size(half, half), cv::Size(-1, -1),
                     cv::TermCriteria(cv::TermCriteria::EPS | cv::TermCriteria::COUNT, 40, 1e-4));
    const cv::Point2f refined = one[0] + cv::Point2f(static_cast<float>(roi.x), static_cast<float>(roi.y));
    if (std::hypot(refined.x - p.x, refined.y - p.y) < max_move_px) p = refined;  // else keep the detector's
  }
}

// Chessboard corners: the window is a third of the smallest square side, at most 20 px: the four
// squares meeting at a corner, never a neighbouring corner.
void RefineChessboardCorners(const cv::Mat& gray, const TargetSpec& t, std::vector<cv::Point2f>* pts) {
  double min_step = 1e30;
  for (int r = 0; r < t.rows; ++r) {
    for (int c = 0; c + 1 < t.cols; ++c) {
      const auto d = (*pts)[r * t.cols + c + 1] - (*pts)[r * t.cols + c];
      min_step = std::min(min_step, static_cast<double>(std::hypot(d.x, d.y)));
    }
  }
  const int half = std::clamp(static_cast<int>(min_step / 3), 2, 20);
  RefineXCorners(gray, half, half >= 8 ? 2.0 : 1.0, 0.25 * min_step, pts);
}

// Mean grey level of a small disc around `centre` (radius r px, clipped to the image).
double MeanAround(const cv::Mat& gray, cv::Point2f centre, int r) {
  const cv::Rect box = cv::Rect(cvRound(centre.x) - r, cvRound(centre.y) - r, 2 * r + 1, 2 * r + 1) &
                       cv::Rect(0, 0, gray.cols, gray.rows);
  if (box.empty()) return 0;
  return cv::mean(gray(box))[0];
}

// One corner numbering for detect, render, the docs and the truth JSON (docs/calibration.md): id =
// row · cols + col on the board, and the square just past corner 0 along +X and +Y (between corners
// 0, 1, cols and cols + 1) is black — the square render draws black (render/pattern.cc). OpenCV's
// findChessboardCornersSB may start from either end of the board; a board whose cols + rows is odd
// (9 × 6: 10 × 7 squares) is not symmetric under a half turn, so the colour of that square decides,
// and a half turn (id k → N − 1 − k) restores the numbering. A board with cols + rows even looks the
// same both ways: its numbering stays OpenCV's (docs/calibration.md says so).
void OrientChessboard(const cv::Mat& gray, const TargetSpec& t, std::vector<cv::Point2f>* pts) {
  if ((t.cols + t.rows) % 2 == 0 || t.cols < 3 || pts->size() != static_cast<std::size_t>(t.cols * t.rows)) return;
  const auto& p = *pts;
  const int c = t.cols;
  // Centres of square (0,0) (black when numbered right) and its neighbour (1,0), each the mean of its four corners.
  const cv::Point2f first = (p[0] + p[1] + p[c] + p[c + 1]) * 0.25f;
  const cv::Point2f next = (p[1] + p[2] + p[c + 1] + p[c + 2]) * 0.25f;
  const double side = std::min(cv::norm(p[1] - p[0]), cv::norm(p[c] - p[0]));
  const int r = std::clamp(static_cast<int>(side / 6), 0, 10);
  if (MeanAround(gray, first, r) > MeanAround(gray, next, r)) std::reverse(pts->begin(), pts->end());
}

// Chessboard search on a reduced copy (`factor` > 1) or the image itself, corners refined on the
// full image.
bool FindChessboard(const cv::Mat& gray, const TargetSpec& t, int factor, std::vector<cv::Point2f>* pts) {
  cv::Mat small = gray;
  if (factor > 1) cv::resize(gray, small, cv::Size(gray.cols / factor, gray.rows / factor), 0, 0, cv::INTER_AREA);
  if (!cv::findChessboardCornersSB(small, cv::Size(t.cols, t.rows), *pts,
                                   cv::CALIB_CB_NORMALIZE_IMAGE | cv::CALIB_CB_EXHAUSTIVE | cv::CALIB_CB_ACCURACY)) {
    return false;
  }
  // Small pixel i covers full pixels [i f, (i+1) f): its centre is at i f + (f-1)/2.
  const float f = static_cast<float>(factor);
  for (auto& p : *pts) p = p * f + cv::Point2f(0.5f * (f - 1), 0.5f * (f - 1));
  RefineChessboardCorners(gray, t, pts);
  OrientChessboard(gray, t, pts);
  return true;
}

bool FindPoints(const cv::Mat& gray, const TargetSpec& t, std::vector<int>* ids,
                std::vector<cv::Point2f>* pts, int factor, coded::UncodedCounts* uncoded, CodedCounts* counts) {
  const cv::Size size(t.cols, t.rows);
  bool found = false;
  switch (t.kind) {
    case TargetKind::kChessboard:
      found = FindChessboard(gray, t, factor, pts);
      break;
    case TargetKind::kCircles:
      // The graph search misses small grids (4×3); the clustering search is the fallback.
      found = cv::findCirclesGrid(gray, size, *pts, cv::CALIB_CB_SYMMETRIC_GRID) ||
              cv::findCirclesGrid(gray, size, *pts,
                                  cv::CALIB_CB_SYMMETRIC_GRID | cv::CALIB_CB_CLUSTERING);
      break;
    case TargetKind::kAsymmetricCircles:
      found = cv::findCirclesGrid(gray, size, *pts, cv::CALIB_CB_ASYMMETRIC_GRID);
      break;
    case TargetKind::kCoded: {  // target IDs of the sheet or field (target.h)
      coded::CodedDetectOptions o;
      o.bits = t.code_bits;
      o.profile = coded::ParseProfile(t.code_profile, "target");
      o.uncoded_dots = HasUncodedDots(t);
      const coded::CodedDetection d = coded::DetectCodedTargets(gray, o);
      if (counts) *counts = {d.counts, 0};
      for (const auto& c : d.targets) {
        if (!t.HasPoint(c.id)) {  // not on the sheet or in the field
          if (counts) ++counts->not_in_target;
          continue;
        }
        ids->push_back(c.id);
        pts->emplace_back(static_cast<float>(c.centre_px.x()), static_cast<float>(c.centre_px.y()));
      }
      if (o.uncoded_dots) {  // the field's uncoded dots, placed from the decoded targets
        const coded::UncodedMatch m = coded::MatchUncodedDots(d, t.field, t.dot_radius_mm, o, gray.cols, gray.rows);
        for (const auto& c : m.dots) {
          ids->push_back(c.id);
          pts->emplace_back(static_cast<float>(c.centre_px.x()), static_cast<float>(c.centre_px.y()));
        }
        if (uncoded) *uncoded = m.counts;
      }
      return ids->size() >= 4;
    }
    case TargetKind::kCharuco: {
      const auto dict = ArucoDictionary(t.dictionary);
      const auto board = cv::aruco::CharucoBoard::create(
          t.cols, t.rows, static_cast<float>(t.spacing_mm), static_cast<float>(t.marker_mm), dict);
      std::vector<int> marker_ids;
      std::vector<std::vector<cv::Point2f>> marker_corners;
      cv::aruco::detectMarkers(gray, dict, marker_corners, marker_ids);
      if (marker_ids.empty()) return false;
      cv::aruco::interpolateCornersCharuco(marker_corners, marker_ids, gray, board, *pts, *ids);
      if (ids->size() < 4) return false;
      RefineCharucoCorners(gray, t, marker_corners, pts);
      return true;
    }
  }
  if (!found) return false;
  ids->resize(pts->size());
  for (std::size_t i = 0; i < ids->size(); ++i) (*ids)[i] = static_cast<int>(i);
  return true;
}

}  // namespace

bool HasUncodedDots(const TargetSpec& t) {
  if (t.kind != TargetKind::kCoded) return false;
  const coded::Profile p = coded::ParseProfile(t.code_profile, "target");
  return std::any_of(t.field.begin(), t.field.end(),
                     [&](const coded::PlacedTarget& x) { return coded::IsUncodedId(p, t.code_bits, x.id); });
}

cv::Ptr<cv::aruco::Dictionary> ArucoDictionary(const std::string& name, const std::string& field) {
  using namespace cv::aruco;
  static const std::map<std::string, PREDEFINED_DICTIONARY_NAME> kNames = {
      {"DICT_4X4_50", DICT_4X4_50},     {"DICT_4X4_100", DICT_4X4_100},
      {"DICT_4X4_250", DICT_4X4_250},   {"DICT_4X4_1000", DICT_4X4_1000},
      {"DICT_5X5_50", DICT_5X5_50},     {"DICT_5X5_100", DICT_5X5_100},
      {"DICT_5X5_250", DICT_5X5_250},   {"DICT_5X5_1000", DICT_5X5_1000},
      {"DICT_6X6_50", DICT_6X6_50},     {"DICT_6X6_100", DICT_6X6_100},
      {"DICT_6X6_250", DICT_6X6_250},   {"DICT_6X6_1000", DICT_6X6_1000},
      {"DICT_7X7_50", DICT_7X7_50},     {"DICT_7X7_100", DICT_7X7_100},
      {"DICT_7X7_250", DICT_7X7_250},   {"DICT_7X7_1000", DICT_7X7_1000},
      {"DICT_ARUCO_ORIGINAL", DICT_ARUCO_ORIGINAL}};
  const auto it = kNames.find(name);
  if (it == kNames.end()) throw InvalidInput(field, "unknown ArUco dictionary " + name);
  return cv::aruco::getPredefinedDictionary(it->second);
}

// ChArUco corners, refined again as the chessboard's: OpenCV's interpolateCornersCharuco returns
// them refined with a bias of about half a pixel in u and v in OpenCV 4.6 (opencv/opencv#25539);
// porthole's own refinement starts from them and converges on the junction whatever OpenCV did.
// Around a ChArUco corner the two white squares hold markers, (square - marker)/2 from the corner,
// whose black border bit ends R = (square - marker)/2 + marker/(bits + 2) from it: the pattern is
// point-symmetric only that far (the markers' inner bits differ), and the markers' borders cross
// the window without passing through the corner. A window of half-size R/2 and a blur of R/5
// do best (measured on renders against their ground truth: 0.011 px RMS with R = 14 px, 0.021 px
// with R = 7 px; render_test.cc). R in px comes from the smallest detected marker (its side
// times square/marker).
void RefineCharucoCorners(const cv::Mat& gray, const TargetSpec& t, const std::vector<std::vector<cv::Point2f>>& markers,
                          std::vector<cv::Point2f>* pts) {
  const int marker_bits = ArucoDictionary(t.dictionary)->markerSize;
  double marker_px = 1e30;
  for (const auto& m : markers) {
    for (std::size_t k = 0; k < m.size(); ++k) {
      const auto d = m[(k + 1) % m.size()] - m[k];
      marker_px = std::min(marker_px, static_cast<double>(std::hypot(d.x, d.y)));
    }
  }
  if (markers.empty() || !(t.marker_mm > 0)) return;
  const double px_per_mm = marker_px / t.marker_mm;
  const double r_px = (0.5 * (t.spacing_mm - t.marker_mm) + t.marker_mm / (marker_bits + 2)) * px_per_mm;
  const int half = std::clamp(static_cast<int>(std::lround(0.5 * r_px)), 2, 20);
  RefineXCorners(gray, half, std::clamp(0.2 * r_px, 0.7, 4.0), 0.25 * t.spacing_mm * px_per_mm, pts);
}

std::optional<std::pair<long, long>> ReadImageSize(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return std::nullopt;
  unsigned char h[32] = {};
  in.read(reinterpret_cast<char*>(h), sizeof h);
  const auto got = in.gcount();
  if (got >= 24 && std::memcmp(h, "\x89PNG\r\n\x1a\n", 8) == 0 && std::memcmp(h + 12, "IHDR", 4) == 0) {
    return std::pair<long, long>(Be32(h + 16), Be32(h + 20));
  }
  if (got >= 26 && h[0] == 'B' && h[1] == 'M') {
    return std::pair<long, long>(std::abs(static_cast<int32_t>(Le32(h + 18))), std::abs(static_cast<int32_t>(Le32(h + 22))));
  }
  if (got >= 3 && h[0] == 'P' && h[1] >= '1' && h[1] <= '6') {  // PNM: "P5 <w> <h> <max>" with comments
    in.clear();
    in.seekg(2);
    long v[2] = {0, 0};
    for (long& x : v) {
      int c = in.get();
      while (c == '#' || std::isspace(c)) {
        if (c == '#') while (c != '\n' && c != EOF) c = in.get();
        c = in.get();
      }
      if (!std::isdigit(c)) return std::nullopt;
      for (int digits = 0; std::isdigit(c) && digits < 12; ++digits, c = in.get()) x = 10 * x + (c - '0');
    }
    return std::pair<long, long>(v[0], v[1]);
  }
  if (got >= 4 && h[0] == 0xff && h[1] == 0xd8) {  // JPEG: walk the markers to a start of frame
    in.clear();
    in.seekg(2);
    for (int markers = 0; markers < 10000; ++markers) {
      unsigned char m[4];
      if (!in.read(reinterpret_cast<char*>(m), 2) || m[0] != 0xff) return std::nullopt;
      while (m[1] == 0xff) {  // fill bytes
        if (!in.read(reinterpret_cast<char*>(m + 1), 1)) return std::nullopt;
      }
      if (m[1] == 0xd8 || m[1] == 0x01 || (m[1] >= 0xd0 && m[1] <= 0xd7)) continue;  // no length
      if (!in.read(reinterpret_cast<char*>(m + 2), 2)) return std::nullopt;
      const int len = Be16(m + 2);
      if (len < 2) return std::nullopt;
      const bool sof = m[1] >= 0xc0 && m[1] <= 0xcf && m[1] != 0xc4 && m[1] != 0xc8 && m[1] != 0xcc;
      if (sof) {
        unsigned char f[5];
        if (!in.read(reinterpret_cast<char*>(f), 5)) return std::nullopt;
        return std::pair<long, long>(Be16(f + 3), Be16(f + 1));
      }
      in.seekg(len - 2, std::ios::cur);
    }
    return std::nullopt;
  }
  if (got >= 8 && ((h[0] == 'I' && h[1] == 'I') || (h[0] == 'M' && h[1] == 'M'))) {  // TIFF: IFD0 tags 256, 257
    const bool le = h[0] == 'I';
    auto u16 = [le](const unsigned char* p) { return le ? Le16(p) : Be16(p); };
    auto u32 = [le](const unsigned char* p) { return le ? Le32(p) : Be32(p); };
    if (u16(h + 2) != 42) return std::nullopt;
    in.clear();
    in.seekg(u32(h + 4));
    unsigned char n[2];
    if (!in.read(reinterpret_cast<char*>(n), 2)) return std::nullopt;
    long size[2] = {-1, -1};
    for (int i = 0, count = u16(n); i < count && i < 1000; ++i) {
      unsigned char e[12];
      if (!in.read(reinterpret_cast<char*>(e), 12)) return std::nullopt;
      const int tag = u16(e), type = u16(e + 2);
      if (tag == 256 || tag == 257) size[tag - 256] = type == 3 ? u16(e + 8) : static_cast<long>(u32(e + 8));
    }
    if (size[0] < 0 || size[1] < 0) return std::nullopt;
    return std::pair<long, long>(size[0], size[1]);
  }
  return std::nullopt;
}

bool DetectInImage(const cv::Mat& gray, const TargetSpec& target, std::vector<int>* ids,
                   std::vector<cv::Point2f>* points, const DetectOptions& options, bool reduce,
                   coded::UncodedCounts* uncoded, CodedCounts* coded) {
  // findChessboardCornersSB draws from the calling thread's cv::theRNG(): left alone, whether a
  // borderline board is found (and where its corners land) depended on which images that thread
  // had searched before, so DetectAll's answers changed with the thread count and the schedule.
  // Each search starts from the state a fresh thread has (OpenCV's default seed).
  cv::theRNG().state = 0xffffffffULL;
  const int long_side = std::max(gray.cols, gray.rows);
  int factor = 1;
  if (reduce && target.kind == TargetKind::kChessboard && long_side > options.reduce_above_px) {
    factor = std::max(2, static_cast<int>(std::lround(double(long_side) / options.reduced_long_side_px)));
  }
  return FindPoints(gray, target, ids, points, factor, uncoded, coded);
}

namespace {

bool IsPng(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  char h[8] = {};
  in.read(h, 8);
  return in.gcount() == 8 && std::memcmp(h, "\x89PNG\r\n\x1a\n", 8) == 0;
}

// The pixels of the images being decoded and searched at once (DetectAll's threads): an image
// waits until the others leave room, so memory follows the budget, not the number of cores.
class PixelBudget {
 public:
  explicit PixelBudget(double total) : total_(total) {}
  void Acquire(double n) {
    std::unique_lock lock(mutex_);
    ready_.wait(lock, [&] { return used_ == 0 || used_ + n <= total_; });  // one image alone always runs
    used_ += n;
  }
  void Release(double n) {
    {
      std::lock_guard lock(mutex_);
      used_ -= n;
    }
    ready_.notify_all();
  }

 private:
  std::mutex mutex_;
  std::condition_variable ready_;
  double total_, used_ = 0;
};

DetectResult DetectTargetIn(const std::string& path, const TargetSpec& target, const std::string& label,
                            const DetectOptions& options, PixelBudget* budget);

}  // namespace

// OpenCV logs on stderr ("[ WARN:0@0.1] global loadsave.cpp … imread_(…): can't open/read file"):
// silenced for the process; each skipped image says why itself, on one line.
cv::Mat ReadPngGray(const std::string& path, std::string* warning, std::string* error, long max_width,
                    long max_height) {
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (f == nullptr) {
    if (error) *error = fmt::format("cannot open: {}", std::strerror(errno));
    return {};
  }
  PngRead read;
  cv::Mat gray = DecodePngGray(f, max_width, max_height, &read);
  std::fclose(f);
  if (warning) *warning = read.warning;
  if (error) *error = read.error;
  return gray;
}

static void QuietOpenCVLogs() {
  static const bool once = [] {
    cv::utils::logging::setLogLevel(cv::utils::logging::LOG_LEVEL_SILENT);
    return true;
  }();
  (void)once;
}

DetectResult DetectTarget(const std::string& path, const TargetSpec& target,
                          const std::string& label, const DetectOptions& options) {
  QuietOpenCVLogs();
  return DetectTargetIn(path, target, label, options, nullptr);
}

namespace {

DetectResult DetectTargetIn(const std::string& path, const TargetSpec& target, const std::string& label,
                            const DetectOptions& options, PixelBudget* budget) {
  DetectResult r;
  // Why an image is skipped, before anything is decoded: missing, not an image porthole reads,
  // too large (from the header's size: decoding a 140 kB PNG declaring 12000 x 12000 px took 2 GB).
  if (FILE* f = std::fopen(path.c_str(), "rb")) {
    std::fclose(f);
  } else {
    r.reason = errno == ENOENT ? "missing file" : fmt::format("cannot open: {}", std::strerror(errno));
    return r;
  }
  const auto size = ReadImageSize(path);
  if (!size) {
    r.reason = "not an image (no PNG, JPEG, TIFF, BMP or PGM/PPM header porthole can read)";
    return r;
  }
  if (size->first < 1 || size->second < 1) {
    r.reason = fmt::format("not an image (its header declares {} x {} px)", size->first, size->second);
    return r;
  }
  const double pixels = double(size->first) * double(size->second);
  if (size->first > options.max_side_px || size->second > options.max_side_px || pixels > options.max_pixels) {
    r.reason = fmt::format("too large: {} x {} px (limit {:g} megapixels, {} px a side)", size->first,
                           size->second, options.max_pixels / 1e6, options.max_side_px);
    return r;
  }
  struct Hold {
    PixelBudget* budget;
    double n;
    ~Hold() {
      if (budget) budget->Release(n);
    }
  } hold{budget, pixels};
  if (budget) budget->Acquire(pixels);
  cv::Mat gray;
  std::vector<int> ids;
  std::vector<cv::Point2f> pts;
  try {
    if (IsPng(path)) {
      std::string warning, error;
      gray = ReadPngGray(path, &warning, &error, size->first, size->second);
      if (!warning.empty()) r.warning = "libpng: " + OneLineMessage(warning, 120);
      if (gray.empty()) {
        r.reason = "decode error (libpng: " + OneLineMessage(error, 120) + ")";
        return r;
      }
    } else {
      gray = cv::imread(path, cv::IMREAD_GRAYSCALE);
    }
    if (gray.empty()) {
      r.reason = "decode error (a damaged or unsupported image)";
      return r;
    }
    if (double(gray.cols) * gray.rows > pixels) {  // the decoder read more than the header declared
      r.reason = fmt::format("decode error ({} x {} px decoded, {} x {} px in its header)", gray.cols, gray.rows,
                             size->first, size->second);
      return r;
    }
    coded::UncodedCounts uncoded;
    CodedCounts coded;
    const bool found = DetectInImage(gray, target, &ids, &pts, options, true, &uncoded, &coded);
    if (HasUncodedDots(target)) r.uncoded = uncoded;
    if (target.kind == TargetKind::kCoded) r.coded = coded;
    if (!found) {
      r.reason = "no target found";
      if (r.coded && r.coded->detector.over_limit > 0) {
        r.reason += fmt::format(" ({} more dot-like blobs beyond the limit of {} candidates per image, not tried)",
                                r.coded->detector.over_limit, coded::CodedDetectOptions{}.max_candidates);
      }
      return r;
    }
  } catch (const cv::Exception& e) {  // OpenCV's own limits and decoder failures
    std::string what = e.err.empty() ? "OpenCV error" : e.err;
    r.reason = "decode error (" + OneLineMessage(what, 120) + ")";
    return r;
  } catch (const std::bad_alloc&) {
    r.reason = "decode error (out of memory decoding it)";
    return r;
  }
  ImageDetections d;
  d.image = label.empty() ? path : label;
  d.width_px = gray.cols;
  d.height_px = gray.rows;
  d.ids = ids;
  for (const auto& p : pts) d.points_px.emplace_back(p.x, p.y);
  d.blur_px = EdgeBlurPx(gray, pts);
  r.detections = std::move(d);
  return r;
}

}  // namespace

double EdgeBlurPx(const cv::Mat& gray, const std::vector<cv::Point2f>& points) {
  if (points.size() < 3 || gray.empty()) return NAN;
  float u0 = points[0].x, u1 = u0, v0 = points[0].y, v1 = v0;
  for (const auto& p : points) {
    u0 = std::min(u0, p.x), u1 = std::max(u1, p.x);
    v0 = std::min(v0, p.y), v1 = std::max(v1, p.y);
  }
  constexpr double kS1 = 1, kS2 = 3;       // the two smoothing scales, px
  constexpr int kEdge = 10;                // > 3 kS2: the box's border, where smoothing sees no image
  const float mu = 0.05f * (u1 - u0) + kEdge, mv = 0.05f * (v1 - v0) + kEdge;
  const cv::Rect box = cv::Rect(cv::Point(int(std::floor(u0 - mu)), int(std::floor(v0 - mv))),
                                cv::Point(int(std::ceil(u1 + mu)) + 1, int(std::ceil(v1 + mv)) + 1)) &
                       cv::Rect(0, 0, gray.cols, gray.rows);
  if (box.width < 2 * kEdge + 3 || box.height < 2 * kEdge + 3) return NAN;
  cv::Mat f;
  gray(box).convertTo(f, CV_32F);
  const cv::Rect inner(kEdge, kEdge, box.width - 2 * kEdge, box.height - 2 * kEdge);
  const cv::Mat dx = (cv::Mat_<float>(1, 3) << -0.5f, 0.f, 0.5f);
  const auto energy = [&](double s) {  // sum of |gradient|^2 after a Gaussian of s px
    cv::Mat g, gx, gy;
    cv::GaussianBlur(f, g, cv::Size(0, 0), s, s, cv::BORDER_REPLICATE);
    cv::filter2D(g, gx, CV_32F, dx, cv::Point(-1, -1), 0, cv::BORDER_REPLICATE);
    cv::filter2D(g, gy, CV_32F, dx.t(), cv::Point(-1, -1), 0, cv::BORDER_REPLICATE);
    return cv::sum(gx(inner).mul(gx(inner)))[0] + cv::sum(gy(inner).mul(gy(inner)))[0];
  };
  const double e1 = energy(kS1), e2 = energy(kS2);
  if (!(e1 > 0 && e2 > 0)) return NAN;
  // An edge of blur b: e ∝ 1 / sqrt(b^2 + s^2 + 1/3) (the central difference adds a box of
  // variance 1/3), so r = e1/e2 gives b^2.
  const double r2 = (e1 / e2) * (e1 / e2);
  if (!(r2 > 1)) return INFINITY;  // no edge finer than the larger scale
  const double b2 = (kS2 * kS2 - r2 * kS1 * kS1) / (r2 - 1) - 1.0 / 3;
  return std::sqrt(std::max(b2, 0.0));
}

std::vector<std::string> ListImages(const std::string& dir, const std::string& field) {
  if (!fs::is_directory(dir)) throw InvalidInput(field, dir + " is not a directory");
  static const std::vector<std::string> kExt = {".jpg", ".jpeg", ".png", ".tif", ".tiff",
                                                ".bmp", ".pgm",  ".ppm"};
  std::vector<std::string> out;
  for (const auto& e : fs::directory_iterator(dir)) {
    std::string ext = e.path().extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), ::tolower);
    if (std::find(kExt.begin(), kExt.end(), ext) != kExt.end()) out.push_back(e.path().string());
  }
  std::sort(out.begin(), out.end());
  if (out.empty()) throw InvalidInput(field, dir + " holds no images (jpg, png, tif, bmp, pgm)");
  if (out.size() > kMaxImagesPerSet) {
    throw InvalidInput(field, fmt::format("{} holds {} images, more than the limit of {} images per set", dir,
                                          out.size(), kMaxImagesPerSet));
  }
  return out;
}

DetectionRun DetectAll(const std::vector<std::string>& paths, const TargetSpec& target,
                       const std::function<void(const std::string&)>& progress, const DetectOptions& options) {
  QuietOpenCVLogs();
  std::vector<DetectResult> results(paths.size());
  PixelBudget budget(options.max_pixels_in_flight);
  std::atomic<std::size_t> next{0};
  std::size_t done = 0;
  std::mutex mutex;
  std::exception_ptr error;
  auto worker = [&] {
    for (std::size_t i = next++; i < paths.size(); i = next++) {
      const std::string label = fs::path(paths[i]).filename().string();
      try {
        results[i] = DetectTargetIn(paths[i], target, label, options, &budget);
      } catch (...) {  // InvalidInput (a bad target dictionary): stop all, rethrow below
        std::lock_guard lock(mutex);
        if (!error) error = std::current_exception();
        next = paths.size();
        return;
      }
      std::lock_guard lock(mutex);
      ++done;
      if (progress) {
        const auto& r = results[i];
        const std::string dots = r.uncoded ? fmt::format(" ({} of {} uncoded dots in view)", r.uncoded->matched, r.uncoded->in_view) : "";
        const std::string note = r.warning.empty() ? "" : "; " + r.warning;
        progress(r.detections ? fmt::format("[{}/{}] {}: {} points{}{}", done, paths.size(), label, r.detections->ids.size(), dots, note)
                              : fmt::format("[{}/{}] {}: skipped ({}){}", done, paths.size(), label, r.reason, note));
      }
    }
  };
  const unsigned hw = std::max(1u, std::thread::hardware_concurrency());
  const std::size_t n_threads = std::min<std::size_t>(options.threads > 0 ? options.threads : hw, paths.size());
  std::vector<std::thread> pool;
  for (std::size_t t = 1; t < n_threads; ++t) pool.emplace_back(worker);
  worker();
  for (auto& t : pool) t.join();
  if (error) std::rethrow_exception(error);
  DetectionRun run;
  for (std::size_t i = 0; i < paths.size(); ++i) {
    if (results[i].detections) {
      run.detections.push_back(std::move(*results[i].detections));
      run.uncoded.push_back(results[i].uncoded);
      run.coded.push_back(results[i].coded);
    } else {
      run.skipped.push_back({fs::path(paths[i]).filename().string(), results[i].reason});
    }
  }
  return run;
}

nlohmann::ordered_json DetectionRunImageJson(const DetectionRun& run, std::size_t k, const TargetSpec& target) {
  nlohmann::ordered_json j = DetectionsToJson(run.detections.at(k), target);
  if (k < run.coded.size() && run.coded[k]) {
    const CodedCounts& c = *run.coded[k];
    const coded::DetectionCounts& d = c.detector;
    j["coded_counts"] = {{"candidates", d.candidates}, {"decoded", d.decoded},       {"partial", d.partial},
                         {"no_ring", d.no_ring},       {"unclear", d.unclear},       {"impossible", d.impossible},
                         {"duplicate", d.duplicate},   {"not_elliptic", d.not_elliptic},
                         {"refine_failed", d.refine_failed}, {"over_limit", d.over_limit},
                         {"not_in_target", c.not_in_target}};
  }
  if (k < run.uncoded.size() && run.uncoded[k]) {
    const coded::UncodedCounts& u = *run.uncoded[k];
    j["uncoded_counts"] = {{"coded", u.coded},         {"in_view", u.in_view},     {"matched", u.matched},
                           {"not_found", u.not_found}, {"ambiguous", u.ambiguous}, {"rejected", u.rejected},
                           {"inconsistent", u.inconsistent}};
  }
  return j;
}

nlohmann::ordered_json DetectionRunToJson(const DetectionRun& run, const TargetSpec& target) {
  nlohmann::ordered_json j = DetectionSetToJson({}, run.skipped, target);
  for (std::size_t k = 0; k < run.detections.size(); ++k) j["images"].push_back(DetectionRunImageJson(run, k, target));
  return j;
}

void ToOpenCVCorrespondences(const std::vector<ImageDetections>& detections,
                             const TargetSpec& target,
                             std::vector<std::vector<cv::Point3f>>* object_points,
                             std::vector<std::vector<cv::Point2f>>* image_points) {
  const auto pts = TargetPoints(target);
  object_points->clear();
  image_points->clear();
  for (const auto& d : detections) {
    object_points->emplace_back();
    image_points->emplace_back();
    for (std::size_t k = 0; k < d.ids.size(); ++k) {
      const auto& p = pts[d.ids[k]];
      object_points->back().emplace_back(p.x(), p.y(), p.z());
      image_points->back().emplace_back(d.points_px[k].x(), d.points_px[k].y());
    }
  }
}

}  // namespace porthole::calib
