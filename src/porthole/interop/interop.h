// Calibration files of the tools users already have, read into and written from a camera of the
// closed model list (camera/camera.h). docs/interop.md gives every mapping with its source. Each
// format is one .cc of interop/ (porthole_json.cc, opencv_storage.cc, colmap.cc, mrcal.cc,
// metashape.cc, calibmar.cc) and one row of the format list in interop.cc, which also detects and
// dispatches; the conversions between models (ConvertCalibration) are refit.cc.
//
//   format        file                         models (porthole ← → format)
//   json          porthole calibration JSON    every model (calib/result_json.h)
//   opencv-yaml   OpenCV FileStorage YAML      opencv ↔ camera_matrix + distortion_coefficients
//   opencv-xml    OpenCV FileStorage XML       (4, 5, 8 entries; 12/14 if the thin-prism and tilt
//                                              terms are 0); kannala-brandt ↔ cv::fisheye's K, D
//                                              (interop/opencv_storage.h)
//   colmap        COLMAP cameras.txt / .bin    opencv ↔ SIMPLE_PINHOLE, PINHOLE, SIMPLE_RADIAL,
//                                              RADIAL, OPENCV, FULL_OPENCV;
//                                              kannala-brandt ↔ OPENCV_FISHEYE
//   mrcal         mrcal .cameramodel           opencv ↔ LENSMODEL_PINHOLE, OPENCV4, OPENCV5, OPENCV8
//   calibmar      calibmar calibration.yaml    as colmap, with σ and the FLATPORT/DOMEPORT housing
//   metashape     Agisoft Metashape / PhotoScan  opencv ↔ frame, kannala-brandt ↔ fisheye (exact
//                 calibration XML              without b2, k4, p3, p4; a refit with them)
//
// Exact pairs convert parameter for parameter (COLMAP's principal point is shifted by 0.5 px: its
// top-left pixel centre is (0.5, 0.5), porthole's (0, 0)); a Brown camera written to a pixel format
// is first refit to the opencv model over the image (camera::BrownToOpenCV), and the refit's RMS is
// returned. The equidistant model is written as kannala-brandt (exact: θ(1 + k1θ² + k2θ⁴)).
//
// σ: a calibration is read with its covariance where the format holds one (porthole JSON,
// Metashape's <covariance>), in porthole's parameter order, carried through the conversion by its
// Jacobian (interop/refit.h); where the format holds none (OpenCV, COLMAP, mrcal) the
// covariance of the adjusted parameters is NaN — unknown, never 0 — and has_covariance false.
#pragma once

#include <array>
#include <cmath>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "porthole/calib/result_json.h"
#include "porthole/camera/camera.h"
#include "porthole/camera/opencv_model.h"

namespace porthole::interop {

// The largest RMS over the image (px) a refit between models may leave (Brown → opencv, opencv →
// Brown, Metashape terms opencv lacks): above it the target model cannot hold the camera and the
// conversion is refused, never written or used. Real conversions leave 0.005–0.2 px
// (docs/interop.md); a refit that moves the image points by a pixel on average is another camera.
inline constexpr double kMaxRefitRmsPx = 1.0;

enum class Format { kJson, kOpenCVYaml, kColmapText, kColmapBinary, kMrcal, kMetashape, kCalibmar, kOpenCVXml };

// "json", "opencv-yaml", "colmap", "colmap-bin", "mrcal", "metashape", "calibmar", "opencv-xml"
// (what --to takes).
std::string_view FormatName(Format f);
// Throws InvalidInput(field, "unknown format … (known: …)").
Format FormatFromName(std::string_view name, const std::string& field);
// All names, comma-separated, for help texts.
std::string FormatNames();

// The format of a file to read, from its extension and content: .json / '{' → json; .yml, .yaml,
// '%YAML' → opencv-yaml; .cameramodel or a Python dict with 'lensmodel' → mrcal; .bin → colmap-bin;
// .txt or lines "ID MODEL W H params…" → colmap; an <opencv_storage> document → opencv-xml; .xml or
// '<' with a <calibration> element → metashape. A directory is read as its cameras.txt (or
// cameras.bin). Throws InvalidInput(field, …) naming the file when nothing matches.
Format DetectInputFormat(const std::string& path, const std::string& content,
                         const std::string& field);
// The format to write `path` in: `to` when given, else from the extension (as above; a file named
// cameras.bin is colmap-bin, anything else .txt colmap).
Format OutputFormat(const std::string& path, const std::optional<std::string>& to,
                    const std::string& field);

// A refractive housing of refractive COLMAP / calibmar (interop/refractive.h has its conventions
// and the conversion to and from porthole's port).
struct RefractiveHousing {
  std::string model;               // "FLATPORT" or "DOMEPORT"
  std::array<double, 8> params{};  // FLATPORT Nx Ny Nz int_dist int_thick na ng nw;
                                   // DOMEPORT Cx Cy Cz int_radius int_thick na ng nw (metres)
  std::array<double, 8> sigma;     // 1σ of each; NaN: unknown
  RefractiveHousing() { sigma.fill(NAN); }
};

// A calibration read from a file, with what the reader knows of it.
struct ReadResult {
  // camera, adjusted parameters, covariance in porthole's order (NaN where unknown), label
  calib::CalibrationRecord calibration;
  Format format;
  std::string format_model;  // the model's name in the file (e.g. "OPENCV", "LENSMODEL_OPENCV8")
  bool pitch_known = false;  // the file gave the pixel pitch (only porthole JSON does)
  bool exact = true;         // false: the file's model was refit into porthole's (fit: its quality)
  camera::ConversionFit fit;
  std::optional<RefractiveHousing> housing;  // calibmar: its FLATPORT / DOMEPORT
  double file_rms_px = NAN;                  // calibmar: its "# overall_rms"
  std::optional<std::array<double, 6>> rt_fromref;  // mrcal: its extrinsics (rotation vector, translation)

  const camera::Camera& camera() const { return calibration.camera; }
};

// What was written, and how faithfully.
struct WriteResult {
  std::string content;       // the file's bytes
  std::string format_model;  // the model's name in the file
  bool exact = true;         // false: a refit (fit holds its quality)
  camera::ConversionFit fit;  // the refit's RMS and max over the image, px (exact: zeros)
  bool sigma_written = false;  // the format holds σ and the calibration had a covariance
};

// Reads a camera from `content` in `format`. Pixel formats carry no pitch: the sensor gets
// `pixel_pitch_mm` (> 0; callers without one pass 1 and say "pixels are mm"). `field` names the
// file in errors: InvalidInput("<field>: <format key>", rule).
// `camera_id`: the camera of a COLMAP file holding several (0: the file must hold one).
ReadResult ReadCalibration(const std::string& content, Format format, double pixel_pitch_mm,
                           const std::string& field, int camera_id = 0);
// Reads a file (or a COLMAP sparse-model directory), detecting its format; the label is the file's
// stem. The one loader of every command that reads a calibration (convert, compare, simulate,
// report).
ReadResult ReadCalibrationFile(const std::string& path, double pixel_pitch_mm, const std::string& field,
                               int camera_id = 0);

// The pixel pitch a calibration file states (porthole JSON's sensor.pixel_pitch_mm); nullopt for a
// format without one. For commands whose camera has no pitch of its own (a lensfun body): the
// calibration's, instead of asking for --pixel-pitch-mm again. Throws as ReadCalibrationFile.
std::optional<double> StatedPixelPitchMm(const std::string& path, const std::string& field);

// `r` with its calibration converted to `model` (ConvertCalibration); exact and fit then describe
// the conversion when it was a refit (else what reading did).
ReadResult ConvertRead(ReadResult r, camera::CameraModelId model, const std::string& field);
// ReadCalibrationFile, then ConvertRead: a calibration of any format as the model a command needs
// (simulate and the report: Brown).
ReadResult ReadCalibrationFileAs(const std::string& path, double pixel_pitch_mm, camera::CameraModelId model,
                                 const std::string& field);
// One line saying how a calibration was read: "<file> (<format> <model>): exact" or "…: refit to
// <model> over the image, RMS … px, max … px".
std::string DescribeRead(const ReadResult& r, const std::string& path);

// Writes the calibration in `format`, with its covariance where the format holds one. Throws
// InvalidInput(field, …) when the model has no representation in the format (e.g. kannala-brandt
// in mrcal, which has no such model).
// What some formats hold besides the camera; the others ignore it.
struct WriteExtras {
  std::optional<RefractiveHousing> housing;          // calibmar's non_svp_model (else NONE)
  std::optional<std::array<double, 6>> rt_fromref;  // mrcal's extrinsics (else the identity)
};
WriteResult WriteCalibration(const calib::CalibrationRecord& cal, Format format, const std::string& field,
                             const WriteExtras& extras = {});
// A camera without σ.
WriteResult WriteCamera(const camera::Camera& cam, Format format, const std::string& field);

// The calibration as a camera of `model`: unchanged when it is already; exact where the two are
// one family (equidistant → kannala-brandt); else a dense refit over the image (opencv ↔ brown,
// camera::BrownToOpenCV / OpenCVToBrown) whose quality lands in `fit`. σ is carried through by the
// conversion's Jacobian. Throws InvalidInput(field, …) for pairs porthole cannot convert.
calib::CalibrationRecord ConvertCalibration(const calib::CalibrationRecord& cal, camera::CameraModelId model,
                                            const std::string& field, camera::ConversionFit* fit = nullptr);

// A record of `cam` whose adjusted parameters (the model's non-zero ones and its focal length and
// principal point) have unknown σ (NaN covariance): what a format without σ gives.
calib::CalibrationRecord WithoutSigma(const camera::Camera& cam, const std::string& note);

// ---- The individual formats (also used by the tests) ----

// COLMAP's model names and ids (colmap/src/base/camera_models.h: SIMPLE_PINHOLE 0, PINHOLE 1,
// SIMPLE_RADIAL 2, RADIAL 3, OPENCV 4, OPENCV_FISHEYE 5, FULL_OPENCV 6).
struct ColmapCamera {
  int camera_id = 1;
  std::string model;
  int width_px = 0, height_px = 0;
  std::vector<double> params;  // COLMAP's order and pixel convention (centre of the first pixel 0.5)
  // Refractive COLMAP (the COLMAP-Underwater fork) appends the housing to a cameras.txt line:
  // "… PARAMS[] FLATPORT|DOMEPORT p1 … p8" (its reconstruction.cc, WriteCamerasText); its later form
  // puts the token REFRAC before the model. Both are read; the first is written.
  std::optional<RefractiveHousing> housing;
};
// The smallest COLMAP model that holds the camera exactly (opencv or kannala-brandt model only).
ColmapCamera ToColmap(const camera::Camera& cam, const std::string& field);
camera::Camera FromColmap(const ColmapCamera& c, double pixel_pitch_mm, const std::string& field);

// Several calibrations in one COLMAP cameras.txt or cameras.bin (format colmap or colmap-bin): each
// with its CAMERA_ID (distinct, ≥ 1) and, in cameras.txt only, its refractive housing. WriteResult
// gives the worst refit and the models joined by ", ". Throws InvalidInput(field, …).
struct ColmapEntry {
  calib::CalibrationRecord calibration;
  int camera_id = 1;
  std::optional<RefractiveHousing> housing;
};
WriteResult WriteColmapCameras(const std::vector<ColmapEntry>& cameras, Format format, const std::string& field);

// mrcal: the lens model name and intrinsics [fx fy cx cy distortion…] (opencv model only).
struct MrcalModel {
  std::string lensmodel;
  std::vector<double> intrinsics;
  int width_px = 0, height_px = 0;
  std::array<double, 6> rt_fromref{};  // extrinsics: rotation vector (rad), translation
};
MrcalModel ToMrcal(const camera::Camera& cam, const std::string& field);
camera::Camera FromMrcal(const MrcalModel& m, double pixel_pitch_mm, const std::string& field);

}  // namespace porthole::interop
