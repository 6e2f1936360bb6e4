// Target detection in images with OpenCV (the only part of calib that links OpenCV):
//  - chessboard: cv::findChessboardCornersSB (sector-based, sub-pixel by its own refinement with
//    CALIB_CB_ACCURACY on the up-sampled image), inner corners row-major;
//  - ChArUco: contrib aruco detectMarkers + interpolateCornersCharuco (ids = OpenCV's corner ids),
//    the corners then refined again by porthole (RefineCharucoCorners);
//  - circle grids: cv::findCirclesGrid, symmetric or asymmetric;
//  - coded circular targets: coded::DetectCodedTargets (coded/detect.h), ids = target IDs; when the
//    target carries a field with uncoded dots (IDs that are no code of the profile), those are
//    matched from the decoded targets (coded::MatchUncodedDots) and reported with their field IDs.
// Pixel convention of OpenCV = porthole's: (0, 0) is the centre of the top-left pixel.
// An unreadable image or one without the target is not an error: it is returned as skipped, with
// why: "missing file", "not an image (…)", "too large: …", "decode error (…)", "no target found".
// Images are untrusted (docs/robustness.md): the dimensions in the file's header are read first and
// an image over DetectOptions::max_pixels is skipped before anything is decoded.
// Large chessboard images are searched on a reduced copy (long side ~kDetectLongSidePx) and the
// corners then refined at full resolution with cv::cornerSubPix: 12 MP in well under a second and a
// fraction of the memory, corners within 0.02 px of full-resolution detection (make bench).
#pragma once

#include <functional>
#include <opencv2/aruco/dictionary.hpp>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "porthole/calib/detections_json.h"
#include "porthole/calib/observations.h"
#include "porthole/calib/target.h"
#include "porthole/coded/detect.h"

namespace porthole::calib {

struct DetectOptions {
  // Images over max_pixels are skipped ("too large") from their header, never decoded. DetectAll
  // decodes and searches images at once only while their pixels sum to max_pixels_in_flight or
  // less (one image alone always runs): peak memory follows these, not the number of cores
  // (docs/robustness.md, "Limits").
  // 48 megapixels: coded detection on a full-range noise image peaks at about 35 MB a megapixel
  // (2.28 GB at 64 megapixels, /usr/bin/time -v), so 48 stay under 2 GB.
  double max_pixels = 48e6;
  double max_pixels_in_flight = 48e6;
  int max_side_px = 40000;           // likewise for either side
  int reduce_above_px = 2400;        // chessboards: search a reduced copy when the long side is larger
  int reduced_long_side_px = 1600;   // ... of about this long side (integer factor)
  int threads = 0;                   // DetectAll: images in parallel; 0 = all cores
};

// OpenCV's predefined ArUco dictionary `name` (DICT_4X4_50, ... DICT_ARUCO_ORIGINAL: the ChArUco
// spec's DICT). Throws InvalidInput(field, ...) for any other name.
cv::Ptr<cv::aruco::Dictionary> ArucoDictionary(const std::string& name, const std::string& field = "target");

// Width and height from an image file's header (PNG, JPEG, BMP, PGM/PPM, TIFF) without decoding
// it; nullopt when the format is not one of these or the header is damaged.
std::optional<std::pair<long, long>> ReadImageSize(const std::string& path);

// A PNG file as 8-bit grey through libpng, pixel for pixel what cv::imread(IMREAD_GRAYSCALE) gives,
// but with libpng's messages kept instead of printed on stderr: *warning gets its first warning,
// *error why it could not be decoded (then the result is empty). libpng's own size limits are set
// to `max_width` x `max_height` (0: none beyond libpng's).
cv::Mat ReadPngGray(const std::string& path, std::string* warning = nullptr, std::string* error = nullptr,
                    long max_width = 0, long max_height = 0);

// Coded targets in one image: the detector's tally of its candidates (what it decoded and why it
// skipped the rest: partial, no ring, unclear, impossible codes, duplicate IDs; blobs that are no
// dot), and the decoded IDs that the sheet or field does not have (dropped).
struct CodedCounts {
  coded::DetectionCounts detector;
  int not_in_target = 0;
};

struct DetectResult {
  std::optional<ImageDetections> detections;  // set when the target was found
  std::string reason;                          // why not: "missing file", "not an image (…)", "too large: …",
                                               // "decode error (…)", "no target found"
  std::string warning;                         // the decoder's first warning, one line ("libpng: …"), or empty
  std::optional<coded::UncodedCounts> uncoded; // a field with uncoded dots: how they were matched
  std::optional<CodedCounts> coded;            // coded targets: set whenever the image was searched
};

// Whether the target is coded and its field holds uncoded dots (IDs no code of its profile).
bool HasUncodedDots(const TargetSpec& target);

// Detects `target` in the image file at `path`. `label` names it in the result (default: path).
DetectResult DetectTarget(const std::string& path, const TargetSpec& target,
                          const std::string& label = "", const DetectOptions& options = {});

// Detection on an image already in memory (8-bit grey); `reduce` false forces full resolution.
// `uncoded` (may be null) gets the matching counts of a field's uncoded dots (HasUncodedDots),
// `coded` (may be null) the coded detector's counts (coded targets).
bool DetectInImage(const cv::Mat& gray, const TargetSpec& target, std::vector<int>* ids,
                   std::vector<cv::Point2f>* points, const DetectOptions& options = {}, bool reduce = true,
                   coded::UncodedCounts* uncoded = nullptr, CodedCounts* coded = nullptr);

// Refines ChArUco corners (px) in place, from wherever a detector left them (within a quarter of a
// square): cv::cornerSubPix on a smoothed patch as for the chessboard, with a window that sees only
// the corner's point-symmetric neighbourhood (up to the markers' inner bits). The scale comes from
// `marker_corners`, the detected markers (4 corners each). DetectInImage applies it: OpenCV 4.6's
// interpolateCornersCharuco leaves its corners half a pixel off (opencv/opencv#25539).
void RefineCharucoCorners(const cv::Mat& gray, const TargetSpec& target,
                          const std::vector<std::vector<cv::Point2f>>& marker_corners,
                          std::vector<cv::Point2f>* corners);

// How blurred the target is in an image: the sigma, px, of the Gaussian that would blur a sharp
// edge as much. Measured from the gradient energy of the bounding box of its detected points
// (margin 5 % + 10 px) after Gaussian smoothing at 1 and 3 px: an edge of blur b gives energies in
// the ratio sqrt(b^2 + 9 + 1/3) / sqrt(b^2 + 1 + 1/3), solved for b. Contrast, the target's size
// in the image and the flat squares' noise hardly count (frames_test: within 0.15 px of the
// blur of a rendered edge, with and without sensor noise). A focused, well-sampled edge gives
// about 0.4-0.7 px. NaN for fewer than 3 points or a box too small; inf when no edge is finer
// than 3 px.
double EdgeBlurPx(const cv::Mat& gray, const std::vector<cv::Point2f>& points);

// Image files (jpg, jpeg, png, tif, tiff, bmp, pgm, ppm; any case) in a directory, sorted by name.
// Throws InvalidInput(field) if the directory does not exist or holds none.
std::vector<std::string> ListImages(const std::string& dir, const std::string& field = "images");

struct DetectionRun {
  std::vector<ImageDetections> detections;
  std::vector<std::optional<coded::UncodedCounts>> uncoded;  // per detections entry (DetectResult::uncoded)
  std::vector<std::optional<CodedCounts>> coded;             // per detections entry (DetectResult::coded)
  std::vector<SkippedImage> skipped;
};

// The run as `porthole detect --json` prints it: DetectionSetToJson, each image with
// `coded_counts` (coded targets: candidates, decoded, partial, no_ring, unclear, impossible,
// duplicate, not_elliptic, refine_failed, over_limit: candidates beyond the per-image limit, not tried;
// not_in_target) and `uncoded_counts` (a field with
// uncoded dots: coded, in_view, matched, not_found, ambiguous, rejected, inconsistent) where known.
nlohmann::ordered_json DetectionRunToJson(const DetectionRun& run, const TargetSpec& target);
// One image's entry of it (run.detections[k]), as `detect --out-dir` writes it.
nlohmann::ordered_json DetectionRunImageJson(const DetectionRun& run, std::size_t k, const TargetSpec& target);

// Detects the target in every image, options.threads images at a time; `progress` (may be empty)
// gets one line per image as each finishes (called from one thread at a time). Results keep the
// order of `paths`.
DetectionRun DetectAll(const std::vector<std::string>& paths, const TargetSpec& target,
                       const std::function<void(const std::string&)>& progress = {},
                       const DetectOptions& options = {});

// The detections as OpenCV's calibrateCamera takes them: per image, target points (target frame,
// mm) and their pixels. For comparisons with OpenCV on the same points.
void ToOpenCVCorrespondences(const std::vector<ImageDetections>& detections,
                             const TargetSpec& target,
                             std::vector<std::vector<cv::Point3f>>* object_points,
                             std::vector<std::vector<cv::Point2f>>* image_points);

}  // namespace porthole::calib
