// --every and --max-frames for the commands whose --images may be a video (detect, calibrate):
// calib/frames.h holds what they mean.
#pragma once

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include "porthole/calib/frames.h"

namespace porthole::cli {

inline void AddFrameOptions(CLI::App* cmd, calib::FrameOptions* f, bool for_calibration) {
  f->for_calibration = for_calibration;
  cmd->add_option("--every", f->every,
                  fmt::format("Search every N-th image or video frame (default: every image; a video, enough to "
                              "search at most {} frames)", f->max_searched))
      ->check(CLI::Range(1, 1000000));
  cmd->add_option("--max-frames", f->max_frames,
                  for_calibration
                      ? fmt::format("Keep K of the frames found, chosen automatically: blurred ones left out, the rest "
                                    "spread over the frame and the target's tilts (default: a video {}, a directory "
                                    "every image)", calib::kCalibrationFrames)
                      : std::string("Keep K of the frames found, chosen automatically: blurred ones left out, the "
                                    "rest spread over the frame and the target's tilts (default: all)"))
      ->check(CLI::Range(1, 1000000));
}

}  // namespace porthole::cli
