// Detection of circular coded targets in an image (OpenCV for the candidate search only).
//
//  1. candidates: the image is thresholded against its local mean both ways (dark and light
//     targets), each blob's outline is fitted with OpenCV's direct least-squares ellipse
//     (cv::fitEllipseDirect, Fitzgibbon 1999) and kept if it fills its ellipse like a dot;
//  2. sub-pixel centre: in the ellipse's affine frame (unit circle ↦ ellipse) rays are cast from
//     the centre and each ray's edge is put where the interpolated intensity crosses the mean of
//     the dot's and the gap's levels; the direct ellipse fit of those edge points (coordinates
//     relative to the previous centre, so float precision is not the limit) gives the next frame,
//     three times. The centre returned is the ellipse's centre: the centre of the IMAGE of the
//     dot, not the image of the dot's centre (ellipse.h gives the difference);
//  3. decoding: the ring is sampled on three circles of the affine frame between the profile's
//     ring radii, 12 samples a bit; the bit phase with the clearest bits is kept, every bit must
//     be clear (level beyond 25 % / 75 % between gap and dot), the gap inside and the band outside
//     the ring must be empty, and the minimal rotation must be one of the profile's codes.
// Anything else is skipped and counted (DetectionCounts), never given an ID.
//
// Pixels: (0, 0) is the centre of the top-left pixel (docs/conventions.md). The ring is read
// clockwise in the image, which is clockwise on the sheet when the sheet is seen from its
// printed side (any view through a lens: a mirror image would read the other way).
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "porthole/coded/codes.h"

namespace porthole::coded {

struct CodedDetectOptions {
  int bits = 14;
  Profile profile = Profile::kAicon;
  double min_dot_diameter_px = 6;     // dots whose image is shorter (long axis) are not tried
  double max_axis_ratio = 4;          // long/short axis of the dot's image (tilt up to ~75°)
  double min_contrast = 0.04;         // |dot − gap| as a fraction of the image type's full range
  double min_bit_clarity = 0.25;      // each bit's level at most this far from 0 or 1 (of dot − gap)
  bool uncoded_dots = false;          // also return the dots that carry no code (CodedDetection::dots)
};

struct CodedTarget {
  int id = 0;
  Eigen::Vector2d centre_px{0, 0};    // centre of the dot's image ellipse
  double semi_major_px = 0, semi_minor_px = 0, angle_rad = 0;  // the ellipse (angle of the major axis from +u toward +v)
  bool dark_on_light = true;          // polarity found
  double clarity = 0;                 // the worst bit's distance from the 50 % level (0 … 0.5)
};

// Why candidates were not reported (each candidate ellipse counted once).
struct DetectionCounts {
  int candidates = 0;        // dot-like blobs tried
  int decoded = 0;           // reported
  int partial = 0;           // ring or edges beyond the image border
  int no_ring = 0;           // no clean gap and ring around the dot (plain dots, look-alikes)
  int unclear = 0;           // some bit between the levels (blur, damage, wrong scale)
  int impossible = 0;        // a clear ring whose code the profile does not have
  int duplicate = 0;         // an ID seen on two separate targets: both dropped
  int not_elliptic = 0;      // the blob's edge is not an ellipse (ring segments, blots)
  int refine_failed = 0;     // the sub-pixel edge fit did not converge
  std::string ToString() const;
};

struct CodedDetection {
  std::vector<CodedTarget> targets;   // ascending ID
  // With CodedDetectOptions::uncoded_dots: the candidates for uncoded dots (id 0, clarity 0), in no
  // particular order — every dot that refined to a clean ellipse with an empty gap around it
  // (halfway from the dot to the profile's ring: 1.5 radii AICON, 1.625 Metashape) and gave no ID:
  // no ring, or
  // what lies where a ring would be is no code of the profile (neighbouring dots and rings in a
  // dense field), or the ring would leave the image. They are counted among the skipped as before
  // (no_ring, unclear, impossible, partial): the option changes neither `targets` nor `counts`.
  std::vector<CodedTarget> dots;
  DetectionCounts counts;
};

// Detects coded targets in a grey image (CV_8U, CV_16U or CV_32F/CV_64F in [0, 1]).
CodedDetection DetectCodedTargets(const cv::Mat& gray, const CodedDetectOptions& options = {});

}  // namespace porthole::coded
