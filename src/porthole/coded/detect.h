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
#include "porthole/coded/sheet.h"

namespace porthole::coded {

struct CodedDetectOptions {
  int bits = 14;
  Profile profile = Profile::kAicon;
  double min_dot_diameter_px = 6;     // dots whose image is shorter (long axis) are not tried
  double max_axis_ratio = 4;          // long/short axis of the dot's image (tilt up to ~75°)
  double min_contrast = 0.04;         // |dot − gap| as a fraction of the image type's full range
  double min_bit_clarity = 0.25;      // each bit's level at most this far from 0 or 1 (of dot − gap)
  bool uncoded_dots = false;          // also return the dots that carry no code (CodedDetection::dots)
  // Candidates tried per image at most (time and memory on a noise image: 42 s of CPU unbounded);
  // the rest are counted in DetectionCounts::over_limit, never tried. A dense field of 30 000
  // targets needs more; docs/robustness.md.
  int max_candidates = 20000;
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
  int over_limit = 0;        // dot-like blobs beyond CodedDetectOptions::max_candidates: not tried
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

// ---- Uncoded dots of a known target field ----
//
// In a target field (ID → X, Y, Z mm; sheet.h), an ID that is no code of the profile at these bits
// — an ID above the profile's code count, e.g. > 516 for AICON 14-bit — is an UNCODED dot: a plain
// dot of the same radius, without a ring. Photogrammetric test fields carry many of them between
// the coded ones. They cannot be read, only recognised where the field says a dot must be once the
// view is known from the decoded targets:
//  1. the field is mapped into the image from the known points (decoded targets, then the dots
//     matched so far): a homography when the known points are coplanar (within 0.2 % of their
//     extent; then only field points on that plane are predicted), else a DLT camera matrix (a
//     3-D field, >= 6 known points); linear, Hartley-normalised;
//  2. each uncoded dot's predicted position is corrected locally by the map's residuals at the
//     nearest known points (a weighted affine fit of them, or their weighted mean when they do not
//     span two directions): lens distortion makes a global projective map poor, but its residual
//     varies slowly across the image;
//  3. the dot is matched to the nearest detected dot only when that is unambiguous: within
//     `tolerance` of the local spacing (the distance in the image to the nearest other predicted
//     field point), the next nearest detected dot (coded or not) `ambiguity_ratio` times farther
//     and beyond the tolerance, no other ID claiming the same dot, the dot's polarity that of the
//     decoded targets and its size (√(ab)) within `size_tolerance` of what the neighbours predict;
//  4. rounds grow the matched set outward from the known points, the map refitted after each: a
//     dot is tried only when a known point lies within `reach` local spacings of its prediction,
//     and taken first only within a third of the tolerance; a round that adds nothing widens the
//     tolerance (×1.5 up to `tolerance`), then the reach (×1.5 up to `max_reach`);
//  5. a leave-one-out check drops matched dots that their neighbours do not predict: the miss
//     of a dot predicted without itself must not exceed `verify_factor` × the median miss of its
//     neighbours (each predicted without itself and without the dot) or `verify_floor` of the
//     spacing, whichever is larger; repeated while it drops dots (5 passes at most).
// A dot that is not the field's but lies where a missing dot of the field should be, closer than
// the leave-one-out check can see (a few hundredths of the spacing), is taken for it: nothing in
// the image tells them apart.
bool IsUncodedId(Profile profile, int bits, int id);

struct UncodedMatchOptions {
  double tolerance = 0.15;       // of the local spacing: farthest a dot may be from its prediction
  double ambiguity_ratio = 3;    // the next nearest dot at least this many times farther than the nearest
  double size_tolerance = 0.25;  // |size / predicted size − 1| at most (size = √(semi-axes product))
  int neighbours = 8;            // known points in the local correction
  double reach = 1.5;            // first round: known points within this many local spacings
  double max_reach = 5;          // ... growing to this
  double verify_factor = 5;      // leave-one-out: a matched dot's error at most this × its neighbours' median
  double verify_floor = 0.05;    // ... or this fraction of the spacing, whichever is larger
};

struct UncodedCounts {
  int coded = 0;        // decoded targets of the field the mapping started from
  int in_view = 0;      // uncoded dots of the field predicted inside the image
  int matched = 0;
  int not_found = 0;    // no detected dot within the tolerance (hidden, missed, not printed, out of reach)
  int ambiguous = 0;    // another dot too close, or one dot claimed by two IDs
  int rejected = 0;     // the nearest dot has the wrong size or polarity
  int inconsistent = 0; // matched, then dropped: off where its neighbours put it (leave-one-out)
  std::string ToString() const;
};

struct UncodedMatch {
  std::vector<CodedTarget> dots;   // matched dots (from CodedDetection::dots), id = field ID, ascending
  UncodedCounts counts;
};

// Matches the uncoded dots of `field` (dot radius `dot_radius_mm`; profile and bits of `detect`)
// among `detection.dots` (DetectCodedTargets with uncoded_dots) in an image of width × height px.
// Nothing is matched with fewer than 4 decoded targets of the field (a homography) or when the
// known points are degenerate. Throws InvalidInput only for bad options.
UncodedMatch MatchUncodedDots(const CodedDetection& detection, const std::vector<PlacedTarget>& field,
                              double dot_radius_mm, const CodedDetectOptions& detect, int width_px, int height_px,
                              const UncodedMatchOptions& options = {});

}  // namespace porthole::coded
