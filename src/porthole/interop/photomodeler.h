// PhotoModeler's text export and DBAT's control-point file, read as porthole detections and a
// target field (docs/interop.md, "PhotoModeler and DBAT").
//
// The export (PhotoModeler "Export Text File", the file DBAT's loadpm reads; Börlin & Grussenmeyer,
// DBAT, github.com/niclasborlin/dbat, code/file/loadpm.m) is whitespace-separated text in blocks
// that end at a blank line:
//   line 1  title
//   line 2  tolerance, max iterations [, image width_px, height_px (appended by hand, as DBAT's
//           manual says; without them `image_size_px` must be given)] (DBAT's manual, "Export from
//           PhotoModeler")
//   line 3  default standard deviations (9 numbers)
//   line 4  the camera: c, xp, yp, format width, format height (mm), K1, K2, K3, P1, P2
//   line 5  its standard deviations (10 numbers)
//   photos  per photo six lines, each opening with the photo number N: "N file name", the exterior
//           orientation (6 numbers), its deviations (6), covariances (3, or a blank line), the
//           photo's camera (10) and its deviations (10); a blank line ends the photos
//   control points, then object points: "id X Y Z sX sY sZ" (project units, metres), each block
//           ending at a blank line
//   marks   "N id x_px y_px sx sy": point `id` marked on photo N; a blank line or the end ends it
//   (feature lists follow; they are not read)
//
// Conventions converted here, nowhere else:
//   - Pixels: PhotoModeler's origin is the top-left corner of the image, so the centre of the
//     top-left pixel is (0.5, 0.5) (DBAT's reading: mm = pixel · pitch from that corner,
//     code/bundle/cameramodel/brown_euler_cam4.m); porthole's is (0, 0) (docs/conventions.md):
//     u = x_px − 0.5, v = y_px − 0.5. PhotoModeler's own solution confirms it (with the principal
//     point and K, P below, its listed residuals come back to 0.018 px RMS; without the shift a
//     0.51 px mean remains: tests/cli/test_photomodeler_cli.py).
//   - The principal point xp, yp is in mm from that corner, y down; porthole's x0, y0 are from the
//     image centre, y up: x0 = xp − format_w/2, y0 = format_h/2 − yp.
//   - K1..K3, P1, P2 are PhotoModeler's correction added to measured coordinates with y up, which is
//     porthole's Brown form (DBAT negates them for its subtracted form): taken as they are.
//   - Object coordinates are in metres (DBAT's object unit for these files): × 1000 to mm.
//   - The pixel pitch is format_h / height_px (DBAT's choice; format_w / width_px differs from it by
//     the affinity, which porthole's B1 absorbs).
//
// DBAT's control-point file (code/file/loadcpt.m): '#' comments and blank lines, otherwise
// comma-separated "id, name, X, Y, Z[, σ…]" with no σ (fixed), one σ (all axes), two (σxy, σz) or
// three (σx, σy, σz), in the project's units (metres here).
//
// Errors: InvalidInput(field, "'<file>' line N: …"), one line, never a crash: a truncated line, a
// number that is not finite, a duplicate photo or point, a mark on an unknown photo or of an unknown
// point, a mark outside the image; more photos or image points than a detection set holds
// (core/input.h).
//
// Control points in the field: FieldPoint::control and sigma_mm (0: fixed, NaN: none given); in the
// target-field file a comment after the point, "# sigma_mm sx sy sz control", which porthole's field
// reader skips: calibrate uses the positions only.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "porthole/calib/observations.h"

namespace porthole::interop {

// The camera as the export gives it (line 4), PhotoModeler's conventions.
struct PhotoModelerCamera {
  double c_mm = 0, xp_mm = 0, yp_mm = 0;          // principal distance; principal point from the corner, y down
  double format_w_mm = 0, format_h_mm = 0;        // sensor format
  double K1 = 0, K2 = 0, K3 = 0, P1 = 0, P2 = 0;  // mm⁻², mm⁻⁴, mm⁻⁶, mm⁻¹, mm⁻¹
};

// The same camera in porthole's Brown convention (docs/conventions.md): mm from the image centre, y up.
struct BrownFromPhotoModeler {
  double pixel_pitch_mm = 0;  // format_h / height_px
  double c_mm = 0, x0_mm = 0, y0_mm = 0;
  double K1 = 0, K2 = 0, K3 = 0, P1 = 0, P2 = 0;
};

// A point of the field, in mm (the export's metres × 1000).
struct FieldPoint {
  int id = 0;
  Eigen::Vector3d xyz_mm = Eigen::Vector3d::Zero();
  Eigen::Vector3d sigma_mm = Eigen::Vector3d::Constant(NAN);  // NaN: none given; 0: fixed
  bool control = false;  // a control point (the export's control block or a control-point file)
  std::string name;      // the control-point file's name, if any
};

struct PhotoModelerProject {
  std::string title;
  int width_px = 0, height_px = 0;
  PhotoModelerCamera camera;
  std::vector<calib::ImageDetections> detections;  // one per photo, in the file's order; porthole pixels
  std::vector<int> photo_numbers;                  // N of each photo
  std::vector<FieldPoint> field;                   // object points then control points not among them, by id
  int n_marks = 0;                                 // image points read
};

struct PhotoModelerOptions {
  // Width and height in pixels when line 2 holds none (or to override it).
  std::optional<std::pair<int, int>> image_size_px;
};

// Reads the export at `path`. Throws InvalidInput(field, …) naming the file and line.
PhotoModelerProject ReadPhotoModelerExport(const std::string& path, const PhotoModelerOptions& options = {},
                                           const std::string& field = "photomodeler");
// The same from text; `origin` names it in messages.
PhotoModelerProject ParsePhotoModelerExport(const std::string& text, const std::string& origin,
                                            const PhotoModelerOptions& options = {},
                                            const std::string& field = "photomodeler");

// PhotoModeler's point tables (CSV, as DBAT's loadpm2dtbl / loadpm3dtbl read them): a "Project
// Units: meters" line (metres when absent; centimeters, millimeters, feet, inches too), a header line,
// then data lines opening with a digit, fields by the header's names. The 2-D table ("Object Point
// ID,Photo #,X (pixels),Y (pixels),…"): the marks, photos numbered from 1 (the export's N + 1), the
// same pixel origin as the export; it names no image file ("photo N") and holds no image size
// (`image_size_px` required). The 3-D table ("Id,Name,Photos (used),X (project units),…"): the points,
// "X Precision" … as σ, "Type" Control marks a control point. No camera is read (`camera` stays 0).
// 2 for a 2-D table, 3 for a 3-D table, 0 for anything else (from the first 20 lines).
int PhotoModelerTableKind(const std::string& text);
PhotoModelerProject ReadPhotoModelerTables(const std::string& path_2d, const std::string& path_3d,
                                           const PhotoModelerOptions& options, const std::string& field = "photomodeler");
PhotoModelerProject ParsePhotoModelerTables(const std::string& text_2d, const std::string& origin_2d,
                                            const std::string& text_3d, const std::string& origin_3d,
                                            const PhotoModelerOptions& options, const std::string& field = "photomodeler");

// Reads DBAT's control-point file: every point control, in mm.
std::vector<FieldPoint> ReadDbatControlPoints(const std::string& path, const std::string& field = "control_points");
std::vector<FieldPoint> ParseDbatControlPoints(const std::string& text, const std::string& origin,
                                               const std::string& field = "control_points");

// Marks the field's points that `control` names as control points with the file's position and σ
// (DBAT's setcpt: the control file's values are the prior). A control id the project never marks
// on a photo is refused (InvalidInput(field, …)).
void ApplyControlPoints(const std::vector<FieldPoint>& control, PhotoModelerProject* project,
                        const std::string& field = "control_points");

// The camera in porthole's Brown convention (above).
BrownFromPhotoModeler BrownCamera(const PhotoModelerProject& project);

// The field as a porthole target-field file (coded/sheet.h ParseField reads it): "id x_mm y_mm z_mm"
// a line; after '#' the σ in mm ("sigma_mm sx sy sz", when given) and "control" for a control point.
std::string FieldFileText(const PhotoModelerProject& project, const std::string& source);

// The target spec string the detections carry: a coded target whose field is the file above
// (`coded:12:1`; the radius matters only for the centre correction, which these marks do not want).
inline constexpr const char* kPhotoModelerTarget = "coded:12:1";

}  // namespace porthole::interop
