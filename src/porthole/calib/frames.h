// Where the images of a set come from, and which of them a calibration uses (issue 28).
//
// `--images` (detect, calibrate) names a directory of images, one image file, or a video file. A
// video's frames are decoded through OpenCV's video support (Debian's FFmpeg backend), every
// `every`-th one searched for the target; each frame found is labelled "f<index, 6 digits>" and
// carries its index and time (ImageDetections::frame_index, time_s), so the frames of one moment
// match across the videos of a rig as same-named files do.
//
// The automatic choice (`max_frames` K > 0), for calibration from video, where consecutive frames
// are near copies and some are blurred by motion:
//  1. blurred frames are rejected: a frame whose target's edge blur (EdgeBlurPx, detect.h: the
//     sigma of a Gaussian, px) is over `max_blur_ratio` times the frames' lower quartile and over
//     it by `min_blur_excess_px` (a set of equally sharp frames loses none; the quartile, not the
//     median, so that a clip of which half the frames are blurred is still judged by its sharp end);
//  2. of the rest, K are chosen greedily, each adding the most to what the chosen ones lack: the
//     cells of a `grid_cols` x `grid_rows` grid over the frame the target covers (each cell worth
//     1 / (1 + times already covered)) and the target's tilt — one of 9 classes (facing the camera,
//     or tilted toward one of 8 directions), worth 1 / (1 + frames chosen in it). The tilt is read
//     from the target's homography alone (no intrinsics): the gradient over the frame of the log of
//     its local scale, times the frame's diagonal, is about 3 tan(tilt) · diagonal / f; above
//     `tilt_threshold` (0.5: about 8° behind a normal lens) the frame is tilted. Ties go to the
//     sharper frame. Chosen frames keep their order in the source.
// A directory's images go through the same choice when `max_frames` is given.
#pragma once

#include <cmath>
#include <functional>
#include <string>
#include <vector>

#include "porthole/calib/detect.h"

namespace porthole::calib {

// The frames a calibration takes from a video when not told (max_frames 0): enough for a
// well-determined camera (the paper used 20-30 images), few enough to adjust in seconds.
inline constexpr int kCalibrationFrames = 40;

enum class SourceKind { kDirectory, kImage, kVideo };

// What `path` is: a directory, an image file (by extension: jpg, jpeg, png, tif, tiff, bmp, pgm,
// ppm), or a video (any other existing file; OpenCV then has to open it). Throws
// InvalidInput(field, …) when it does not exist.
SourceKind ClassifySource(const std::string& path, const std::string& field);

struct FrameOptions {
  int every = 0;       // search every N-th image or frame; 0: 1 for images, for a video enough to
                       // search at most max_searched frames
  int max_searched = 600;  // video with every = 0: the most frames searched
  int max_frames = 0;      // K > 0: the automatic choice of K (above); 0: every frame found, or
                           // for_calibration and a video, kCalibrationFrames
  bool for_calibration = false;
  double max_blur_ratio = 2;
  double min_blur_excess_px = 0.5;
  int grid_cols = 6, grid_rows = 4;
  double tilt_threshold = 0.5;
};

// What the choice did, for the user (Describe) and the JSON outputs.
struct FrameChoice {
  SourceKind kind = SourceKind::kDirectory;
  std::string source;         // the path given
  long frames_in_source = 0;  // images in the directory, or the video's frame count
  double fps = 0;             // a video's frame rate (0: not a video)
  int every = 1;              // the step used
  long searched = 0;          // images or frames searched
  long found = 0;             // with the target
  long blurred = 0;           // rejected as blurred (in run.skipped with their blur)
  long chosen = 0;            // kept (all found but the blurred when max_frames is 0)
  double reference_blur_px = NAN;  // the lower quartile of the frames found
  int cells_covered = 0, cells = 0;  // the grid cells the kept frames' targets cover
  int tilt_classes = 0;              // of the 9
};

// The detections of a source, after the choice.
struct SourceRun {
  DetectionRun run;
  FrameChoice choice;
};

// Detects `target` in every image or every `every`-th frame of `path` (threads as DetectAll; a
// video is decoded on one thread while the others search), then applies the choice.
// `progress` gets one line per image or frame searched and one when the choice is made. Throws
// InvalidInput(field, …) for a path that is no directory, image or video OpenCV can open.
SourceRun DetectSource(const std::string& path, const TargetSpec& target, const FrameOptions& frames,
                       const std::function<void(const std::string&)>& progress = {},
                       const DetectOptions& options = {}, const std::string& field = "images");

// The choice alone, on detections already made (their blur_px set; NaN counts as sharp):
// blurred frames moved to run->skipped, the frames not chosen dropped. Fills the choice's counts
// from `found` on.
void ChooseFrames(DetectionRun* run, const TargetSpec& target, const FrameOptions& frames, FrameChoice* choice);

// The choice as JSON for the outputs that used its frames (detect --json, calibrate): source, kind
// ("directory", "image", "video"), frames_in_source, fps, every, searched, found, blurred, kept,
// reference_blur_px, cells_covered, cells, tilt_classes, and "frames": each kept image's name with
// its frame_index and time_s (a video).
nlohmann::ordered_json FrameChoiceToJson(const FrameChoice& c, const std::vector<ImageDetections>& kept);

// One line: "clip.mp4: video, 1800 frames at 30 fps; every 3rd searched (600), the target in 580;
// 12 blurred, left out (the frames' lower quartile of edge blur 0.61 px); 40 kept, covering 24 of 24 grid cells, 9 of 9 tilt classes".
std::string Describe(const FrameChoice& c);

}  // namespace porthole::calib
