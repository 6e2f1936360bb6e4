// `porthole convert` as one library call (docs/interop.md): calibration files of any format read by
// interop.h, written in another, with the format rules — which outputs hold several cameras (COLMAP
// only), which hold a housing (calibmar, COLMAP cameras.txt), that a directory OUT means COLMAP's
// cameras.txt / cameras.bin, how the refit statistics of several reads combine — and rigs between
// the rig formats of rig_files.h. The CLI and the Python module fill ConvertOptions, call Convert and
// print or return its result (ConvertJson: what `porthole convert --json` prints).
//
// Errors name the options' fields (`inputs`, `out`, `to`, `pixel_pitch_mm`, `camera_id`, `port`,
// `port_out`, `water_index`, `length_unit`, `image_size_px`, `force`); each front end says them in its
// own words. Nothing is written unless every output may be (core/output.h's rule, checked first).
#pragma once

#include <cmath>
#include <functional>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "porthole/interop/interop.h"
#include "porthole/interop/rig_files.h"

namespace porthole::interop {

struct ConvertOptions {
  // The calibration(s) to read (field "inputs"): files or COLMAP sparse-model directories; several
  // are written into one COLMAP file (CAMERA_ID 1, 2, … in their order); or a rig file (ROS
  // camera_info: one file per camera, in rig order).
  std::vector<std::string> inputs;
  // The file to write (field "out"); an existing directory: its cameras.txt (or cameras.bin with
  // `to` colmap-bin); ros-camera-info: a directory, created when missing.
  std::string out;
  // The output format: a name of FormatNames() or RigFormatNames() (field "to"); unset: from
  // out's extension. A rig format name makes a rig conversion.
  std::optional<std::string> to;
  // The pixel pitch for inputs that state none (all but porthole JSON), mm; unset: 1 (pixels are mm).
  std::optional<double> pixel_pitch_mm;
  int camera_id = 0;  // the camera of a COLMAP file holding several (its CAMERA_ID; 0: it holds one)
  // A calibmar or refractive COLMAP input: its housing written as a porthole port TOML here (field
  // "port_out"; empty: not written).
  std::string port_out;
  // A calibmar or COLMAP cameras.txt output: the housing to write for every camera, a port preset
  // name or TOML file (field "port"; empty: the input's housing, if any).
  std::string port;
  std::optional<double> water_index;  // with `port`: the water's index (unset: seawater, Quan–Fry)
  // Rig files whose T has no stated unit (OpenCV stereo, VIAME npz not written by porthole): "mm",
  // "cm" or "m" (field "length_unit"; empty: unstated).
  std::string length_unit;
  // VIAME npz not written by porthole (it holds no image size): width, height in px.
  std::optional<std::pair<int, int>> image_size_px;
  bool force = false;  // replace existing outputs (core/output.h's rule)
  // A front end's words for the options a text written into a file names as `field` (the port TOML's
  // description: "give `water_index`"), e.g. the CLI's flags; unset: the field names, unquoted.
  std::function<std::string(std::string_view)> words;
};

// One input as read.
struct ConvertedInput {
  std::string path;
  ReadResult read;
};

struct ConvertResult {
  bool rig = false;  // a rig conversion (rig_* below), else a calibration conversion
  std::vector<std::string> inputs;
  std::string out;                     // the path written (a directory OUT: its cameras.txt / .bin)
  std::vector<std::string> out_files;  // every file written, port_out included
  // Plausibility warnings of the options (core/plausible.h), naming their fields.
  std::vector<std::string> warnings;

  // A calibration conversion.
  std::vector<ConvertedInput> reads;  // one per input, in order
  Format format = Format::kJson;      // what was written
  WriteResult written;
  // The conversion as a whole: exact, or the refit it was (reading a Metashape model with terms
  // porthole lacks, writing Brown to a pixel format), the largest of several by RMS.
  bool exact = true;
  camera::ConversionFit fit;
  bool several = false;           // several inputs into one COLMAP file
  bool housing_written = false;   // the output holds a housing (the input's or `port`'s)
  std::string port_out;           // where the input's housing went as a port TOML (empty: nowhere)
  double port_water_index = NAN;  // the water index the input's housing states (with port_out)

  // A rig conversion.
  RigFile rig_in;
  RigFormat rig_format = RigFormat::kJson;
  RigWriteResult rig_written;
  bool pitch_given = false;  // pixel_pitch_mm was given (the rig JSON's "pitch")
};

// Whether `options` make a rig conversion: `to` names a rig format, or the first input is a rig
// file (several ROS camera_info files are a rig only into porthole JSON; one is a camera).
bool IsRigConversion(const ConvertOptions& options);

// The plausibility warnings of the options (the pixel pitch), as Convert returns them.
std::vector<std::string> ConvertWarnings(const ConvertOptions& options);

// Reads every input, writes the output(s) under core/output.h's rule (never an input, a COLMAP
// folder's cameras.txt/.bin and `port` included; an existing file only with `force`), and says what
// was written. Throws InvalidInput naming the field; nothing is written then.
ConvertResult Convert(const ConvertOptions& options);

// What `porthole convert --json` prints. Strings that name an option do so as `field` (front ends
// rename them: core/field_names.h).
nlohmann::ordered_json ConvertJson(const ConvertResult& result);

}  // namespace porthole::interop
