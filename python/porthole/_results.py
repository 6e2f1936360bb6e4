"""porthole's results as typed Python objects: floats (infinity is math.inf, never the string "inf"),
numpy arrays for vectors, matrices and table columns, enums for statuses and kinds.

The compiled bindings hand back the CLI's JSON (as `porthole <command> --json` prints it); the classes
here are built from it and give it back with to_dict(), so a result can be saved as the file the CLI
reads (`json.dump(result.to_dict(), f)`).
"""
from __future__ import annotations

import copy
import re
import dataclasses
import enum
import json
import math
import os
import warnings as _warnings
from typing import Any, Dict, List, NamedTuple, Optional, Tuple

import numpy as np

from . import _porthole

__all__ = [
    "RayStatus", "PortType", "CameraModel", "Status", "Record", "Table", "PortholeWarning", "Plan", "FlatAnalysis",
    "Simulation", "Comparison", "HousingAssembly", "ReportSummary", "Detections", "SkippedImage", "DetectionSet",
    "Calibration", "PortCalibration", "RefractiveCalibration", "VirtualImage", "VirtualImageTable", "PortFocal", "TraceResult", "SphereFit",
    "DomeFit", "Preset", "Medium", "ConvertResult", "RenderResult", "RenderedImage", "RenderSet",
]


class RayStatus(enum.IntEnum):
    """What became of a traced ray (optics/trace.h); TraceResult.status holds these as integers."""
    OK = 0                          #: reached the far side
    MISSED = 1                      #: no intersection ahead of the ray
    OUTSIDE_APERTURE = 2            #: hit a surface where it has no glass (beyond a dome's rim)
    TOTAL_INTERNAL_REFLECTION = 3   #: refraction impossible


def _enum_of(name: str, values, doc: str):
    """A str enum whose values are the C++ list's names (member names: upper case, '-' as '_'), so a
    new camera model or port shape needs no line here."""
    e = enum.Enum(name, [(v.upper().replace("-", "_"), v) for v in values], type=str, module=__name__)
    e.__doc__ = doc
    return e


#: The kind of a port: PortType.DOME, .FLAT, .CYLINDER — the port list (ports/port.h; port_shapes()).
PortType = _enum_of("PortType", _porthole.port_shapes(), "The kind of a port (ports/port.h's list; port_shapes()).")

#: The camera models porthole calibrates and projects with (camera/models.h; camera_models()).
CameraModel = _enum_of("CameraModel", [m["name"] for m in _porthole.camera_models()],
                       "The camera models porthole calibrates and projects with (camera/models.h; camera_models()).")


class Status(str, enum.Enum):
    """Outcome of an adjustment or fit: OK, or NOT_USABLE with the reason in the result's `message`."""
    OK = "ok"
    NOT_USABLE = "not usable"


_INF = {"inf": math.inf, "-inf": -math.inf}


def _is_number(x) -> bool:
    """A JSON number, null (an unavailable number) or the CLI's "inf" / "-inf"."""
    return x is None or (isinstance(x, (int, float)) and not isinstance(x, bool)) or (isinstance(x, str) and x in _INF)


def _float(x) -> float:
    """A JSON number as a float: null is NaN, "inf" is math.inf."""
    if x is None:
        return math.nan
    if isinstance(x, str):
        return _INF[x]
    return float(x)


def _identifier(key: str) -> str:
    out = "".join(c if c.isalnum() or c == "_" else "_" for c in key)
    return "_" + out if out[:1].isdigit() else out


def convert(value):
    """One JSON value as porthole's Python types: "inf" -> math.inf, a list of numbers -> a float
    (or int) numpy array, a list of equal-length number lists -> a 2-D array, a list of objects with
    the same number-valued keys -> a Table, an object -> a Record."""
    if isinstance(value, str):
        return _INF.get(value, value)
    if isinstance(value, dict):
        return Record(value)
    if isinstance(value, list) and value:
        if all(_is_number(x) for x in value):
            if all(isinstance(x, int) and not isinstance(x, bool) for x in value):
                return np.array(value, dtype=np.int64)
            return np.array([_float(x) for x in value], dtype=float)
        if all(isinstance(x, list) and x and all(_is_number(y) for y in x) for x in value) \
                and len({len(x) for x in value}) == 1:
            return np.array([[_float(y) for y in x] for x in value], dtype=float)
        if all(isinstance(x, dict) for x in value) and len({tuple(x) for x in value}) == 1 \
                and all(_is_number(v) or isinstance(v, (str, bool)) for x in value for v in x.values()):
            return Table(value)
        return [convert(x) for x in value]
    return value


class Record:
    """A result object: every JSON field of the CLI's output as an attribute (units in the names),
    numbers as floats (math.inf for infinity), vectors and tables as numpy arrays. fields() lists
    them; to_dict() gives the JSON back."""

    def __init__(self, data: Dict[str, Any]):
        object.__setattr__(self, "_json", data)
        for key, value in data.items():
            object.__setattr__(self, _identifier(key), convert(value))

    def fields(self) -> List[str]:
        """The attribute names, in the JSON's order."""
        return [_identifier(k) for k in self._json]

    def to_dict(self) -> Dict[str, Any]:
        """The result as the CLI's JSON (a deep copy): json.dump() it to get the CLI's file."""
        return copy.deepcopy(self._json)

    def __repr__(self):
        parts = []
        for name in self.fields()[:8]:
            v = getattr(self, name)
            text = f"<{type(v).__name__}>" if isinstance(v, (Record, Table, list, np.ndarray)) else repr(v)
            parts.append(f"{name}={text}")
        more = ", ..." if len(self._json) > 8 else ""
        return f"{type(self).__name__}({', '.join(parts)}{more})"

    def __setattr__(self, name, value):
        raise AttributeError(f"{type(self).__name__} is read-only")

    def __eq__(self, other):
        return type(self) is type(other) and self._json == other._json


class Table:
    """Rows of a table (a JSON list of flat objects) as columns: each column is an attribute holding a
    numpy array (numbers; math.inf for infinity, NaN where unavailable) or a list (text);
    len() is the number of rows, table[i] one row as a Record; columns() gives a dict for pandas."""

    def __init__(self, rows: List[Dict[str, Any]]):
        object.__setattr__(self, "_rows", rows)
        keys = list(rows[0]) if rows else []
        cols = {}
        for key in keys:
            values = [r[key] for r in rows]
            if all(_is_number(v) for v in values):
                cols[_identifier(key)] = np.array([_float(v) for v in values], dtype=float)
            elif all(isinstance(v, bool) for v in values):
                cols[_identifier(key)] = np.array(values, dtype=bool)
            else:
                cols[_identifier(key)] = [convert(v) for v in values]
        object.__setattr__(self, "_columns", cols)
        for name, col in cols.items():
            object.__setattr__(self, name, col)

    def columns(self) -> Dict[str, Any]:
        """{column name: array or list}: pandas.DataFrame(table.columns()) makes a data frame."""
        return dict(self._columns)

    def fields(self) -> List[str]:
        """The column names."""
        return list(self._columns)

    def to_dict(self) -> List[Dict[str, Any]]:
        """The rows as the CLI's JSON list."""
        return copy.deepcopy(self._rows)

    def __len__(self):
        return len(self._rows)

    def __getitem__(self, i) -> Record:
        return Record(self._rows[i])

    def __iter__(self):
        return (Record(r) for r in self._rows)

    def __repr__(self):
        return f"Table({len(self)} rows: {', '.join(self._columns)})"

    def __setattr__(self, name, value):
        raise AttributeError("Table is read-only")


class PortholeWarning(UserWarning):
    """An input porthole ran with but doubts: a value outside the range of any physical camera, lens
    or port (most likely a unit typed wrong: 5.5 for a pixel pitch of 5.5 um). The result's
    `warnings` holds the same text, as `porthole <command> --json` does."""


# The phrase of the library's plausibility warnings (core/plausible.h, kImplausiblePhrase).
_IMPLAUSIBLE = "is outside the range of any physical camera or port"


def _keywords(text: str) -> str:
    """The library's `field` in Python's words: the keyword `field=`."""
    return re.sub(r"`([a-z_][a-z0-9_]*)`", r"\1=", text)


class _WarnsRecord(Record):
    """A Record whose `warnings` list the library filled: its plausibility warnings are also emitted
    with Python's warnings.warn (category PortholeWarning), pointing at the caller's line."""

    def __init__(self, data: Dict[str, Any]):
        if data.get("warnings"):
            # The library names the options its advice mentions as `field`: in Python, a keyword.
            data = dict(data, warnings=[_keywords(str(w)) for w in data["warnings"]])
        super().__init__(data)
        for text in data.get("warnings") or []:
            if _IMPLAUSIBLE in text:
                _warnings.warn(text, PortholeWarning, stacklevel=4)


class Plan(_WarnsRecord):
    """porthole.plan(): the dive plan as `porthole plan --json` (focus, minimum WD, close-up lenses,
    depth of field, field of view, GSD, field curvature); attributes follow its JSON keys. `warnings`
    holds the plausibility warnings of its inputs (also emitted as PortholeWarning) and the advice."""


class FlatAnalysis(_WarnsRecord):
    """porthole.flat(): the flat-port analysis as `porthole flat --json` (FOV in air and water, the
    maximum FOV, the Eq. 1 table, lateral colour). `warnings` as for Plan."""


class Simulation(_WarnsRecord):
    """porthole.simulate(): the calibration to expect behind a port, as `porthole simulate --json`
    (water, air, change, predicted_water, radial_profile; sweep and map when asked). `warnings` as
    for Plan."""


class Comparison(Record):
    """porthole.compare(): two calibrations compared (parameters table with sigma and z, chi2 test,
    p_value, significant, radial and decentring curves in um)."""


class HousingAssembly(Record):
    """porthole.assemble(): the paper's Table 4 in the housing frame (flanges, dome centres and radii,
    the entrance pupil and its offsets from the dome's centres, the transforms from the survey and
    scan frames), as `porthole assemble --json`, and `port`: the as-built PortSpec."""


class ReportSummary(_WarnsRecord):
    """porthole.report(): where the report is (index_html, report_json), its figures and timings, and
    warnings: the plausibility warnings of its inputs (also emitted as PortholeWarning)."""


class ConvertResult(_WarnsRecord):
    """porthole.convert(): what `porthole convert --json` prints (in, in_format, out, out_format,
    out_model, exact, refit_rms_px, sigma, housing, ...; a rig: n_cameras, cameras, pitch, ...), with
    out_files (every file written) and warnings (the options' plausibility, also emitted as
    PortholeWarning)."""


class RenderResult(_WarnsRecord):
    """porthole.render(): what `porthole render --json` prints (image, truth: the files written;
    width_px, height_px, points, blocked_fraction, seconds, ...), ground_truth (the truth JSON beside
    the image: camera, pose, bands, and every target point's pixel per band) and warnings."""


class RenderedImage(Record):
    """One image of porthole.render(set=...) or render(rig=...): camera (a rig's camera; "" for one
    camera), medium (water, air), frame (render, pose_NNN), image and truth (the files written),
    points, blocked_fraction, seconds, ... (one camera's set also width_px, height_px) and
    ground_truth (the truth JSON beside the image: camera, pose, bands, every target point's pixel
    per band; a rig's image also its `rig` block: camera, cam_from_rig, rig_from_target)."""


class RenderSet(_WarnsRecord):
    """porthole.render(set=N) or render(rig=..., baseline_mm=...): what `porthole render --set N` or
    `--rig` prints with --json (a set: poses, focus_distance_mm, images {water, air}; a rig: cameras,
    frames, images, and with set=N focus_distance_mm per camera), `renders`: every image written as a
    RenderedImage (with its ground_truth), in the order rendered, and warnings (the plausibility
    warnings, also emitted as PortholeWarning, and any note: a lens focused at its closest, a rig
    port's glass taken from `port`)."""

    def __init__(self, data: Dict[str, Any]):
        super().__init__(data)
        object.__setattr__(self, "renders", [RenderedImage(r) for r in data.get("renders", [])])

    def of(self, camera: Optional[str] = None, medium: Optional[str] = None) -> List[RenderedImage]:
        """The renders of one camera (a rig's camera name; None: every camera) in one medium ("water",
        "air"; None: both), in frame order."""
        return [r for r in self.renders
                if (camera is None or r.camera == camera) and (medium is None or r.medium == medium)]


class Preset(NamedTuple):
    """A built-in preset: kind (port, camera, lens), name, description."""
    kind: str
    name: str
    description: str


class Medium(NamedTuple):
    """A medium of the index models: name and description."""
    name: str
    description: str


@dataclasses.dataclass(frozen=True)
class Detections:
    """The target points found in one image. Pixels: (0, 0) is the centre of the top-left pixel,
    u right, v down (OpenCV's convention)."""
    image: str
    width_px: int
    height_px: int
    ids: np.ndarray        #: target point id of each point (int)
    points_px: np.ndarray  #: (N, 2) pixels (u, v)
    target: str = ""       #: the target spec, e.g. "chessboard:9x6:25"
    #: coded targets: the detector's counts (candidates, decoded, and why the rest were skipped:
    #: partial, no_ring, unclear, impossible, duplicate, not_elliptic, refine_failed; not_in_target)
    coded_counts: Optional[Dict[str, int]] = None
    #: a field with uncoded dots: coded, in_view, matched, not_found, ambiguous, rejected, inconsistent
    uncoded_counts: Optional[Dict[str, int]] = None
    frame_index: Optional[int] = None  #: a video frame: its index in the file (from 0)
    time_s: Optional[float] = None     #: a video frame: its time in the file, s
    blur_px: Optional[float] = None    #: the target's edge blur, px (the sigma of a Gaussian)

    @classmethod
    def from_dict(cls, d: Dict[str, Any]) -> "Detections":
        pts = np.array(d.get("points_px") or [], dtype=float).reshape(-1, 2)
        blur = d.get("blur_px")
        return cls(image=d["image"], width_px=int(d["width_px"]), height_px=int(d["height_px"]),
                   ids=np.array(d.get("ids") or [], dtype=np.int64), points_px=pts, target=d.get("target", ""),
                   coded_counts=d.get("coded_counts"), uncoded_counts=d.get("uncoded_counts"),
                   frame_index=d.get("frame_index"), time_s=d.get("time_s"),
                   blur_px=None if blur is None else float(blur))

    def to_dict(self) -> Dict[str, Any]:
        """As `porthole detect` writes one image's file."""
        out = {"image": self.image}
        if self.frame_index is not None:
            out["frame_index"] = int(self.frame_index)
            out["time_s"] = float(self.time_s)
        if self.blur_px is not None:
            out["blur_px"] = float(self.blur_px) if math.isfinite(self.blur_px) else "inf"
        if self.target:
            out["target"] = self.target
        out.update({"width_px": self.width_px, "height_px": self.height_px, "ids": [int(i) for i in self.ids],
                    "points_px": [[float(u), float(v)] for u, v in self.points_px]})
        if self.coded_counts is not None:
            out["coded_counts"] = dict(self.coded_counts)
        if self.uncoded_counts is not None:
            out["uncoded_counts"] = dict(self.uncoded_counts)
        return out


class SkippedImage(NamedTuple):
    """An image in which no target was used, and why."""
    image: str
    reason: str


@dataclasses.dataclass(frozen=True)
class DetectionSet:
    """porthole.detect(): the detections of a target in a set of images (iterable over `images`)."""
    target: str
    images: List[Detections]
    skipped: List[SkippedImage]
    #: where the images came from and which were kept (a folder, one image or a video: kind, fps,
    #: every, searched, found, blurred, kept, reference_blur_px, cells_covered, tilt_classes, frames)
    source: Optional[Dict[str, Any]] = None

    @classmethod
    def from_dict(cls, d: Dict[str, Any]) -> "DetectionSet":
        return cls(target=d.get("target", ""), images=[Detections.from_dict(i) for i in d.get("images", [])],
                   skipped=[SkippedImage(s["image"], s["reason"]) for s in d.get("skipped", [])],
                   source=d.get("source"))

    def to_dict(self) -> Dict[str, Any]:
        """As `porthole detect --json` prints the set."""
        return {"target": self.target, "images": [i.to_dict() for i in self.images],
                "skipped": [{"image": s.image, "reason": s.reason} for s in self.skipped]}

    def __iter__(self):
        return iter(self.images)

    def __len__(self):
        return len(self.images)


def _square(block: Optional[Dict[str, Any]]) -> Tuple[List[str], np.ndarray]:
    if not block or not block.get("parameters"):
        return [], np.zeros((0, 0))
    return list(block["parameters"]), np.array([[_float(x) for x in row] for row in block["matrix"]], dtype=float)


@dataclasses.dataclass(frozen=True, eq=False)
class Calibration:
    """porthole.calibrate(): a camera calibration (the paper's Table 6 for any camera model).

    params maps each parameter key of the model (units in the key, or in `units`: Brown c_mm,
    x0_mm, y0_mm, K1 mm^-2 ...) to its value; a parameter that was not adjusted is 0.0 or its fixed
    value. sigma holds 1-sigma of the adjusted ones (NaN for the others). covariance and correlation
    are square arrays over `adjusted` (in that order)."""
    model: CameraModel
    params: Dict[str, float]
    sigma: Dict[str, float]
    units: Dict[str, str]
    adjusted: List[str]
    covariance: np.ndarray
    correlation: np.ndarray
    sigma0_px: float
    rms_px: float
    dot_radius_mm: float          #: circular targets: the dot radius the centres were corrected for (0: no correction)
    max_centre_offset_px: float   #: the largest centre offset that correction applied (dot-image centre - projected centre)
    width_px: int
    height_px: int
    pixel_pitch_mm: float
    n_images: int
    n_points: int
    n_rejected: int
    redundancy: int
    images: List[Record]          #: per image: image, n_points, n_rejected, rms_px, rotation_rad, translation_mm
    significance: Optional[Table]  #: per free distortion parameter: parameter, t, significant
    status: Status
    message: str                   #: "ok" or why the result is not usable
    warnings: List[str]            #: plausibility warnings of the inputs (a pixel pitch in um), as the CLI prints them
    _json: Dict[str, Any] = dataclasses.field(repr=False)

    @classmethod
    def from_dict(cls, d: Dict[str, Any]) -> "Calibration":
        """From calibrate()'s JSON, `porthole calibrate --json`/--out or a hand-written
        {"camera": {...}, "sigma": {...}, "sensor": {...}} file (the paper's Table 6)."""
        cam = d.get("camera", {})
        sig = d.get("sigma", {}) or {}
        params = {k: (0.0 if v is None else float(v)) for k, v in cam.items()}
        sigma = {k: _float(sig.get(k)) for k in cam}
        names, cov = _square(d.get("covariance"))
        cnames, corr = _square(d.get("correlation"))
        adjusted = names or cnames or [k for k in cam if sig.get(k) is not None]
        sensor = d.get("sensor", {})
        message = str(d.get("status", "ok"))
        signif = d.get("significance")
        return cls(model=CameraModel(d.get("model", "brown")), params=params, sigma=sigma,
                   units=dict(d.get("units", {})), adjusted=adjusted, covariance=cov, correlation=corr,
                   sigma0_px=_float(d.get("sigma0_px")), rms_px=_float(d.get("rms_px")),
                   dot_radius_mm=_float(d.get("dot_radius_mm", 0.0)),
                   max_centre_offset_px=_float(d.get("max_centre_offset_px", 0.0)),
                   width_px=int(sensor.get("width_px", 0)), height_px=int(sensor.get("height_px", 0)),
                   pixel_pitch_mm=_float(sensor.get("pixel_pitch_mm")), n_images=int(d.get("n_images", 0)),
                   n_points=int(d.get("n_points", 0)), n_rejected=int(d.get("n_rejected", 0)),
                   redundancy=int(d.get("redundancy", 0)), images=[Record(i) for i in d.get("images", [])],
                   significance=Table(signif) if signif else None,
                   status=Status.OK if message.startswith("ok") else Status.NOT_USABLE, message=message,
                   warnings=[str(w) for w in d.get("warnings") or []], _json=copy.deepcopy(d))

    def to_dict(self) -> Dict[str, Any]:
        """The calibration as `porthole calibrate --json` prints it (what every command reads)."""
        return copy.deepcopy(self._json)

    def save(self, path) -> None:
        """Writes the calibration JSON file that `porthole compare/simulate/report` read."""
        with open(os.fspath(path), "w") as f:
            json.dump(self._json, f, indent=2)


def _numbers(block: Optional[Dict[str, Any]]) -> Dict[str, float]:
    return {k: _float(v) for k, v in (block or {}).items()}


@dataclasses.dataclass(frozen=True, eq=False)
class PortCalibration:
    """The port measured by a refractive calibration (calibrate(..., port=...), `porthole calibrate
    --port`; docs/calibration.md). params, sigma, predicted, predicted_sigma and units are keyed by
    the port's parameters: a dome's ep_in_dome_{x,y,z}_mm (the entrance pupil minus the outer
    sphere's centre, cam axes), a flat port's normal_x, normal_y, distance_mm; sigma is NaN for a
    parameter held at its prediction. correlation maps each adjusted port parameter to its
    correlation with every other adjusted parameter (lens, port, shell). chi2 / dof / p_value test
    the estimate against the prediction (the port file and pupil). shell holds the water index
    factor and shell values when adjusted (free_water_index, free_shell); n_water is the index
    used. estimated_port is the port as calibrated (a PortSpec: .to_toml() is --port-out's file)."""
    name: str
    type: PortType
    intrinsics: str                 #: "prior", "fixed" or "free"
    n_water: float
    n_glass: float
    params: Dict[str, float]
    sigma: Dict[str, float]
    units: Dict[str, str]
    predicted: Dict[str, float]
    predicted_sigma: Dict[str, float]
    correlation: Dict[str, Dict[str, float]]
    chi2: float
    dof: int
    p_value: float
    differs_from_predicted: bool
    geometry: Record                #: the estimated port in the housing frame
    shell: Record                   #: free, parameters, sigma, from_port_file, n_water, correlation
    central_prediction: Record      #: water c, x0, y0: simulate's prediction against the estimate's
    model_choice: Record            #: BIC of the refractive against the central model
    estimated_port: Any = dataclasses.field(repr=False)

    @classmethod
    def from_dict(cls, d: Dict[str, Any], estimated_port: Any = None) -> "PortCalibration":
        """From the `port` block of `porthole calibrate --port --json`."""
        shell = d.get("shell", {})
        return cls(name=str(d.get("name", "")), type=PortType(d["kind"]), intrinsics=str(d["intrinsics"]),
                   n_water=_float(shell.get("n_water", d.get("n_water"))), n_glass=_float(d.get("n_glass")),
                   params=_numbers(d.get("parameters")), sigma=_numbers(d.get("sigma")),
                   units=dict(d.get("units", {})), predicted=_numbers(d.get("predicted")),
                   predicted_sigma=_numbers(d.get("predicted_sigma")),
                   correlation={k: _numbers(v) for k, v in d.get("correlation", {}).items()},
                   chi2=_float(d.get("chi2")), dof=int(d.get("dof", 0)), p_value=_float(d.get("p_value")),
                   differs_from_predicted=bool(d.get("differs_from_predicted")),
                   geometry=Record(d.get("geometry", {})), shell=Record(shell),
                   central_prediction=Record(d.get("central_prediction", {})),
                   model_choice=Record(d.get("model_choice", {})), estimated_port=estimated_port)


@dataclasses.dataclass(frozen=True, eq=False)
class RefractiveCalibration(Calibration):
    """calibrate(..., port=...): the lens behind the port (a Calibration: params, sigma, covariance
    ... of the lens model, in-air sense) and the port measured from the images (`port`, a
    PortCalibration). to_dict() / save() give the JSON of `porthole calibrate --port --json`."""
    port: PortCalibration = dataclasses.field(default=None)

    @classmethod
    def from_dict(cls, d: Dict[str, Any], estimated_port: Any = None,
                  warnings: Optional[List[str]] = None) -> "RefractiveCalibration":
        """From the JSON of `porthole calibrate --port --json` (and the estimated PortSpec); warnings:
        calibrate()'s, the pitch's and the port's (else the JSON's, the pitch's)."""
        base = Calibration.from_dict(d)
        fields = {f.name: getattr(base, f.name) for f in dataclasses.fields(Calibration)}
        if warnings is not None:
            fields["warnings"] = [str(w) for w in warnings]
        return cls(**fields, port=PortCalibration.from_dict(d["port"], estimated_port))


@dataclasses.dataclass(frozen=True, eq=False)
class RigCamera(Calibration):
    """One camera of a rig (calibrate_rig()): its Calibration (params, sigma, ... of its lens model)
    plus its name, cam_from_rig (x_cam = R(rotation_rad)·x_rig + translation_mm; the rig frame is the
    first camera's) with sigma (6: rotation rad, then translation mm), the baseline from the first
    camera (mm) with its sigma, the convergence angle (deg), the frames it sees, and, behind a port,
    `port` (name, kind, parameters, sigma, predicted) and `estimated_port`, the port as estimated
    (a PortSpec in the housing frame: estimated_port.to_toml() is `calibrate --port-out`'s file)."""
    name: str = ""
    rotation_rad: np.ndarray = dataclasses.field(default=None)
    translation_mm: np.ndarray = dataclasses.field(default=None)
    pose_sigma: np.ndarray = dataclasses.field(default=None)
    baseline_mm: float = 0.0
    baseline_sigma_mm: float = 0.0
    convergence_deg: float = 0.0
    n_frames: int = 0
    port: Optional[Record] = None
    estimated_port: Any = None

    @classmethod
    def from_dict(cls, d: Dict[str, Any], estimated_port=None) -> "RigCamera":
        base = Calibration.from_dict(d)
        fields = {f.name: getattr(base, f.name) for f in dataclasses.fields(Calibration)}
        pose = d["cam_from_rig"]
        sigma = pose["sigma"]
        return cls(**fields, name=d["name"], rotation_rad=np.array(pose["rotation_rad"], dtype=float),
                   translation_mm=np.array(pose["translation_mm"], dtype=float),
                   pose_sigma=np.array([_float(x) for x in sigma["rotation_rad"] + sigma["translation_mm"]]),
                   baseline_mm=_float(d["baseline_mm"]), baseline_sigma_mm=_float(d["baseline_sigma_mm"]),
                   convergence_deg=_float(d["convergence_deg"]), n_frames=int(d["n_frames"]),
                   port=Record(d["port"]) if "port" in d else None, estimated_port=estimated_port)


@dataclasses.dataclass(frozen=True, eq=False)
class RigCalibration:
    """calibrate_rig(): a rig of cameras (`porthole calibrate --detections A --detections B ...`):
    `cameras` (RigCamera each), the frames, sigma0_px and rms_px over all cameras, status, and
    warnings: the plausibility warnings of the pitches and the ports, as the CLI prints them (also
    emitted as PortholeWarning). to_dict() gives the JSON of the CLI."""
    cameras: List[RigCamera]
    n_frames: int
    n_points: int
    sigma0_px: float
    rms_px: float
    status: str
    _dict: Dict[str, Any] = dataclasses.field(repr=False)
    warnings: List[str] = dataclasses.field(default_factory=list)

    @classmethod
    def from_dict(cls, d: Dict[str, Any], estimated_ports=None) -> "RigCalibration":
        """estimated_ports: each camera's estimated PortSpec (calibrate_rig's), or None."""
        rig = d["rig"]
        ports = list(estimated_ports) if estimated_ports is not None else [None] * len(rig["cameras"])
        warnings = [str(w) for w in d.get("warnings") or []]
        d = {k: v for k, v in d.items() if k != "warnings"}  # the CLI's JSON holds none (stderr)
        return cls(cameras=[RigCamera.from_dict(c, p) for c, p in zip(rig["cameras"], ports)], n_frames=int(rig["n_frames"]),
                   n_points=int(rig["n_points"]), sigma0_px=_float(rig["sigma0_px"]), rms_px=_float(rig["rms_px"]),
                   status=rig["status"], _dict=d, warnings=warnings)

    def to_dict(self) -> Dict[str, Any]:
        """The JSON of `porthole calibrate --json` for the rig ({"rig": {...}})."""
        return copy.deepcopy(self._dict)


@dataclasses.dataclass(frozen=True)
class MeasuredPoint:
    """One object point triangulated through the rig (measure()): frame, id, the cameras that saw
    it, x_mm (rig frame, np.ndarray of 3), sigma_mm and sigma_image_mm (3 each), covariance_mm2 (3x3),
    miss_mm (the largest distance from one of its rays), residual_px and range_mm per camera, chi2,
    dof, p_value, mismatched (the rays do not meet within the image noise); ok False with `why` when
    it could not be triangulated (then the arrays are None)."""
    frame: str
    id: int
    cameras: List[str]
    ok: bool
    why: str = ""
    x_mm: Optional[np.ndarray] = None
    sigma_mm: Optional[np.ndarray] = None
    sigma_image_mm: Optional[np.ndarray] = None
    covariance_mm2: Optional[np.ndarray] = None
    miss_mm: float = math.nan
    residual_px: Optional[np.ndarray] = None
    range_mm: Optional[np.ndarray] = None
    chi2: float = math.nan
    dof: int = 0
    p_value: float = math.nan
    mismatched: bool = False

    @classmethod
    def from_dict(cls, d: Dict[str, Any]) -> "MeasuredPoint":
        if not d["ok"]:
            return cls(frame=d["frame"], id=int(d["id"]), cameras=list(d["cameras"]), ok=False, why=d["why"])
        arr = lambda k: np.array([_float(x) for x in d[k]])
        return cls(frame=d["frame"], id=int(d["id"]), cameras=list(d["cameras"]), ok=True, x_mm=arr("x_mm"),
                   sigma_mm=arr("sigma_mm"), sigma_image_mm=arr("sigma_image_mm"),
                   covariance_mm2=np.array([[_float(x) for x in row] for row in d["covariance_mm2"]]),
                   miss_mm=_float(d["miss_mm"]), residual_px=arr("residual_px"), range_mm=arr("range_mm"),
                   chi2=_float(d["chi2"]), dof=int(d["dof"]), p_value=_float(d["p_value"]),
                   mismatched=bool(d["mismatched"]))


@dataclasses.dataclass(frozen=True)
class MeasuredLength:
    """A length between two ids in one frame (measure()): length_mm with sigma_mm (and in %),
    sigma_image_mm and sigma_calibration_mm; ok False with `why` when a point was not triangulated."""
    frame: str
    id_a: int
    id_b: int
    ok: bool
    why: str = ""
    length_mm: float = math.nan
    sigma_mm: float = math.nan
    sigma_percent: float = math.nan
    sigma_image_mm: float = math.nan
    sigma_calibration_mm: float = math.nan

    @classmethod
    def from_dict(cls, d: Dict[str, Any]) -> "MeasuredLength":
        if not d["ok"]:
            return cls(frame=d["frame"], id_a=int(d["id_a"]), id_b=int(d["id_b"]), ok=False, why=d["why"])
        return cls(frame=d["frame"], id_a=int(d["id_a"]), id_b=int(d["id_b"]), ok=True,
                   length_mm=_float(d["length_mm"]), sigma_mm=_float(d["sigma_mm"]),
                   sigma_percent=_float(d["sigma_percent"]), sigma_image_mm=_float(d["sigma_image_mm"]),
                   sigma_calibration_mm=_float(d["sigma_calibration_mm"]))


@dataclasses.dataclass(frozen=True, eq=False)
class Measurement:
    """measure(): the points and lengths measured through a rig, the image sigma used (sigma_px and
    where it came from), what the calibration's uncertainty covers, counts and warnings, and with
    scale_bar=(a, b, length_mm) the check (a Record: mean_error_mm, z, consistent, verdict, by_range,
    frames). to_dict()
    gives the JSON of `porthole measure --json`."""
    points: List[MeasuredPoint]
    lengths: List[MeasuredLength]
    sigma_px: float
    sigma_px_from: str
    covariance: str
    n_failed: int
    n_mismatched: int
    n_unpaired_skipped: int
    warnings: List[str]
    scale_bar: Optional[Record]
    _dict: Dict[str, Any] = dataclasses.field(repr=False)

    @classmethod
    def from_dict(cls, d: Dict[str, Any]) -> "Measurement":
        m = d["measure"]
        return cls(points=[MeasuredPoint.from_dict(p) for p in m["points"]],
                   lengths=[MeasuredLength.from_dict(x) for x in m["lengths"]], sigma_px=_float(m["sigma_px"]),
                   sigma_px_from=m["sigma_px_from"], covariance=m["covariance"], n_failed=int(m["n_failed"]),
                   n_mismatched=int(m["n_mismatched"]), n_unpaired_skipped=int(m["n_unpaired_skipped"]),
                   warnings=list(m["warnings"]), scale_bar=Record(m["scale_bar"]) if "scale_bar" in m else None,
                   _dict=d)

    def to_dict(self) -> Dict[str, Any]:
        """The JSON of `porthole measure --json` ({"measure": {...}})."""
        return copy.deepcopy(self._dict)


@dataclasses.dataclass(frozen=True)
class VirtualImage:
    """Where a port images an axial object at wd_mm (object to the outer vertex): d_s2ep_mm from the
    entrance pupil, vwd_mm from the outer vertex (the paper's D_S2EP and VWD), lateral magnification,
    the image's lateral offset from the axis (decentred ports), and the two focal lines of an
    astigmatic port (a cylinder; both d_s2ep_mm for a symmetric port; 0 for real rays), all mm."""
    wd_mm: float
    d_s2ep_mm: float
    vwd_mm: float
    magnification: float
    lateral_offset_mm: float
    focal_line_near_d_s2ep_mm: float = 0.0
    focal_line_far_d_s2ep_mm: float = 0.0


@dataclasses.dataclass(frozen=True)
class PortFocal:
    """Paraxial focal properties of a port: power (1/mm), effective focal lengths in air and in
    water, back and front focal distances (mm; math.inf for a flat port)."""
    power_per_mm: float
    efl_air_mm: float
    efl_water_mm: float
    back_focal_mm: float
    front_focal_mm: float


@dataclasses.dataclass(frozen=True)
class VirtualImageTable:
    """The paper's Table 5 for a port (as `porthole virtual-image --json`): one entry per working
    distance in each column, paraxial and by real rays through a pupil circle of radius
    aperture_height_mm (NaN where the real rays fail); spherical_aberration_mm = real - paraxial."""
    wd_mm: np.ndarray
    d_s2ep_mm: np.ndarray
    vwd_mm: np.ndarray
    d_s2ep_real_mm: np.ndarray
    vwd_real_mm: np.ndarray
    spherical_aberration_mm: np.ndarray
    image_offset_real_mm: np.ndarray
    magnification: np.ndarray
    aperture_height_mm: float
    focal: PortFocal

    def columns(self) -> Dict[str, np.ndarray]:
        """{column: array}: pandas.DataFrame(table.columns()) makes a data frame."""
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self)
                if isinstance(getattr(self, f.name), np.ndarray)}


@dataclasses.dataclass(frozen=True)
class TraceResult:
    """Rays after a port: origins (N, 3) mm on the last surface, unit directions (N, 3), and status
    (N,) integers of RayStatus (compare with RayStatus.OK; only those rays are meaningful)."""
    origins_mm: np.ndarray
    directions: np.ndarray
    status: np.ndarray

    def ok(self) -> np.ndarray:
        """Boolean mask of the rays that came through."""
        return self.status == RayStatus.OK


@dataclasses.dataclass(frozen=True)
class SphereFit:
    """A sphere fitted to a scan (as `porthole fit sphere --json`): centre and radius (mm) with their
    1-sigma, the 4x4 covariance of (cx, cy, cz, R) in mm^2, residual statistics, per-point signed
    residuals and inlier flags. status NOT_USABLE says why in message."""
    center_mm: np.ndarray
    radius_mm: float
    sigma_center_mm: np.ndarray
    sigma_radius_mm: float
    covariance_mm2: np.ndarray
    sigma0_mm: float
    rms_mm: float
    max_abs_residual_mm: float
    n_points: int
    n_inliers: int
    converged: bool
    residuals_mm: np.ndarray
    is_inlier: np.ndarray
    status: Status
    message: str

    @classmethod
    def from_dict(cls, d: Dict[str, Any]) -> "SphereFit":
        return cls(center_mm=np.asarray(d["center_mm"], float), radius_mm=float(d["radius_mm"]),
                   sigma_center_mm=np.asarray(d["sigma_center_mm"], float), sigma_radius_mm=float(d["sigma_radius_mm"]),
                   covariance_mm2=np.asarray(d["covariance_mm2"], float), sigma0_mm=float(d["sigma0_mm"]),
                   rms_mm=float(d["rms_mm"]), max_abs_residual_mm=float(d["max_abs_residual_mm"]),
                   n_points=int(d["n_points"]), n_inliers=int(d["n_inliers"]), converged=bool(d["converged"]),
                   residuals_mm=np.asarray(d["residuals_mm"], float), is_inlier=np.asarray(d["is_inlier"], bool),
                   status=Status.OK if d["usable"] else Status.NOT_USABLE, message=d["message"])


@dataclasses.dataclass(frozen=True)
class DomeFit:
    """A dome shell from scans of its two surfaces (the paper's Table 3): both sphere fits, the
    thickness R_out - R_in with its sigma, the inner centre minus the outer one (mm) and its length,
    the thinnest and thickest wall, deviations from the nominal (NaN without one)."""
    outer: SphereFit
    inner: SphereFit
    thickness_mm: float
    sigma_thickness_mm: float
    center_offset_mm: np.ndarray
    center_distance_mm: float
    sigma_center_distance_mm: float
    min_wall_mm: float
    max_wall_mm: float
    outer_radius_deviation_mm: float
    thickness_deviation_mm: float
    status: Status
    report: str

    @classmethod
    def from_dict(cls, d: Dict[str, Any]) -> "DomeFit":
        scalars = ("thickness_mm", "sigma_thickness_mm", "center_distance_mm", "sigma_center_distance_mm",
                   "min_wall_mm", "max_wall_mm", "outer_radius_deviation_mm", "thickness_deviation_mm")
        return cls(outer=SphereFit.from_dict(d["outer"]), inner=SphereFit.from_dict(d["inner"]),
                   center_offset_mm=np.asarray(d["center_offset_mm"], float),
                   status=Status.OK if d["usable"] else Status.NOT_USABLE, report=d["report"],
                   **{k: float(d[k]) for k in scalars})
