"""porthole: optics and geometry of underwater camera housings, for notebooks.

Units follow docs/conventions.md: mm, nm, degC, PSU, dbar, degrees in results; every field name
carries its unit. Options are keyword arguments (a misspelt one raises TypeError); bad input raises
ValueError whose message starts with the keyword at fault ("f_number: must be ..."). Results are typed
objects: floats (math.inf for infinity), numpy arrays, enums for statuses (porthole._results).

A whole calibration from a notebook:

    import porthole
    dets = porthole.detect("air/", "chessboard:9x6:25")          # DetectionSet
    cal = porthole.calibrate(dets, "chessboard:9x6:25", pixel_pitch_mm=0.0055)   # Calibration
    cal.params["c_mm"], cal.sigma["c_mm"], cal.covariance
    porthole.virtual_image_table(port="nimar-ni320").d_s2ep_mm   # Table 5 as numpy columns
    porthole.plan(port="nimar-ni320", wd_mm=1000).focus          # the dive plan
    porthole.report("my-report", air_calibration=cal, force=True)
"""
from __future__ import annotations

import contextlib
import math
import os
import tempfile
import warnings as _warnings
from typing import Any, Callable, Iterable, Optional, Union

import numpy as np

from . import _porthole
from ._results import (CameraModel, Calibration, Comparison, DetectionSet, Detections, DomeFit, FlatAnalysis,
                       HousingAssembly,
                       Medium, Plan, PortCalibration, PortFocal, PortholeWarning, PortType, Preset, RayStatus,
                       RefractiveCalibration, RigCalibration, RigCamera, Measurement, MeasuredPoint, MeasuredLength,
                       Record, ReportSummary, Simulation,
                       SkippedImage, SphereFit, Status, Table, TraceResult, VirtualImage, VirtualImageTable)
from ._results import ConvertResult, RenderResult, RenderedImage, RenderSet, _IMPLAUSIBLE

__version__: str = _porthole.__version__

PortSpec = _porthole.PortSpec
PortSpec.type = property(lambda self: PortType(self._type), doc="PortType.DOME, PortType.FLAT or PortType.CYLINDER.")


def _plain(value):
    """Typed results back to the JSON the bindings take (Calibration, Detections, DetectionSet)."""
    if isinstance(value, DetectionSet):
        return [d.to_dict() for d in value.images]
    if hasattr(value, "to_dict"):
        return value.to_dict()
    if isinstance(value, (list, tuple)) and value and any(hasattr(v, "to_dict") for v in value):
        return [_plain(v) for v in value]
    return value


def _wraps(core: Callable, returns: str, doc: str = "") -> Callable[[Callable], Callable]:
    """Gives a wrapper the compiled function's name and signature line (its return type named) and
    docstring, plus `doc`."""
    def decorate(f):
        lines = (core.__doc__ or "").split("\n")
        if lines and "->" in lines[0]:
            lines[0] = lines[0].rsplit("->", 1)[0] + "-> " + returns
        f.__doc__ = "\n".join(lines).strip() + ("\n\n" + doc if doc else "")
        f.__name__ = f.__qualname__ = core.__name__
        f.__module__ = __name__
        return f
    return decorate


def _core_doc(name: str) -> str:
    return getattr(_porthole, name).__doc__ or ""


# --- materials --------------------------------------------------------------------------------

index = _porthole.index
depth_to_pressure_dbar = _porthole.depth_to_pressure_dbar


@_wraps(_porthole.media, "list[porthole.Medium]")
def media():
    return [Medium(*m) for m in _porthole.media()]


# --- ports ------------------------------------------------------------------------------------

load_port = _porthole.load_port


@_wraps(_porthole.presets, "list[porthole.Preset]")
def presets():
    return [Preset(*p) for p in _porthole.presets()]


DEFAULT_WD_MM = (200.0, 300.0, 400.0, 500.0, 750.0, 1000.0, 3000.0, 5000.0, 10000.0, math.inf)


class PortSystem:
    """A port placed in front of an entrance pupil in a given water (place()): refractive indices
    resolved, housing frame (mm; +Z toward the scene). `warnings`: the port's plausibility warnings
    (a radius or thickness in the wrong unit), as `porthole virtual-image` and `trace` print them;
    place() emits each as a PortholeWarning."""

    def __init__(self, system, warnings=()):
        self._sys = system
        self.warnings = list(warnings)

    @property
    def n_glass(self) -> float:
        """Index of the port's glass relative to air."""
        return self._sys.n_glass

    @property
    def n_water(self) -> float:
        """Index of the water relative to air."""
        return self._sys.n_water

    @property
    def ep_in_housing_mm(self) -> np.ndarray:
        """The entrance pupil in the housing frame, mm."""
        return np.asarray(self._sys.ep_in_housing_mm, float)

    @property
    def is_central(self) -> bool:
        """True when chief rays pass the port unrefracted (pupil at a concentric dome's centre)."""
        return self._sys.is_central

    @property
    def outer_vertex_z_mm(self) -> float:
        """z of the port's outer vertex on the axis (housing frame), mm."""
        return self._sys.outer_vertex_z_mm

    @property
    def type(self) -> PortType:
        """PortType.DOME, PortType.FLAT or PortType.CYLINDER."""
        return PortType(self._sys._type)

    def virtual_image(self, wd_mm: float) -> VirtualImage:
        """Paraxial virtual image of an axial object at wd_mm from the outer vertex (math.inf allowed)."""
        return VirtualImage(**self._sys.virtual_image(wd_mm))

    def virtual_image_real(self, wd_mm: float, aperture_height_mm: float = 1.5) -> Optional[VirtualImage]:
        """Virtual image by real rays through a pupil circle of radius aperture_height_mm (1.5 mm: a
        24 mm lens at f/8); None when the rays fail."""
        v = self._sys.virtual_image_real(wd_mm, aperture_height_mm)
        return None if v is None else VirtualImage(**v)

    def focal(self) -> PortFocal:
        """Paraxial focal properties of the port in this water."""
        return PortFocal(**self._sys.focal())

    def virtual_image_table(self, wd_mm: Iterable[float] = DEFAULT_WD_MM,
                            aperture_height_mm: float = 1.5) -> VirtualImageTable:
        """The paper's Table 5 for this port: paraxial and real-ray virtual images of objects at the
        working distances wd_mm (as `porthole virtual-image --json`)."""
        wds = np.asarray(list(wd_mm), dtype=float)
        par = [self.virtual_image(w) for w in wds]
        real = [self.virtual_image_real(w, aperture_height_mm) for w in wds]
        col = lambda xs, name: np.array([math.nan if x is None else getattr(x, name) for x in xs], float)
        d_real = col(real, "d_s2ep_mm")
        d_par = col(par, "d_s2ep_mm")
        return VirtualImageTable(wd_mm=wds, d_s2ep_mm=d_par, vwd_mm=col(par, "vwd_mm"), d_s2ep_real_mm=d_real,
                                 vwd_real_mm=col(real, "vwd_mm"), spherical_aberration_mm=d_real - d_par,
                                 image_offset_real_mm=col(real, "lateral_offset_mm"),
                                 magnification=col(par, "magnification"),
                                 aperture_height_mm=float(aperture_height_mm), focal=self.focal())

    def describe(self) -> dict:
        """The port as `porthole virtual-image --json` gives it (its `port` block, the one port JSON):
        name, type, material, glass_index, the shape's fields (housing frame, mm), outer_vertex_z_mm."""
        return self._sys.describe()

    def trace_out(self, origins_mm, directions) -> TraceResult:
        """Traces (N, 3) rays from inside the housing out into the water (batched, all cores)."""
        return TraceResult(*self._sys.trace_out(np.asarray(origins_mm, float), np.asarray(directions, float)))

    def trace_in(self, origins_mm, directions) -> TraceResult:
        """Traces (N, 3) rays from the water into the housing."""
        return TraceResult(*self._sys.trace_in(np.asarray(origins_mm, float), np.asarray(directions, float)))

    def __repr__(self):
        return (f"PortSystem({self.type.value}, n_glass={self.n_glass:.5f}, n_water={self.n_water:.5f}, "
                f"ep_in_housing_mm={self.ep_in_housing_mm.tolist()})")


@_wraps(_porthole.place, "porthole.PortSystem")
def place(port, **kwargs) -> PortSystem:
    if isinstance(port, (str, os.PathLike)):
        port = load_port(os.fspath(port))
    system = PortSystem(*_porthole.place(port, **kwargs))
    for text in system.warnings:  # as the CLI prints them on stderr
        _warnings.warn(text, PortholeWarning, stacklevel=2)
    return system


def virtual_image_table(*, port: str = "nimar-ni320", wd_mm: Iterable[float] = DEFAULT_WD_MM,
                        aperture_height_mm: float = 1.5, **water) -> VirtualImageTable:
    """The paper's Table 5 for a port (a preset name, a port TOML file or a PortSpec) in a water, as
    `porthole virtual-image --json`: place(port, **water).virtual_image_table(wd_mm, aperture_height_mm).
    Water keywords are place()'s: water, water_index, glass_index, ep_mm, lambda_nm, temperature_c,
    salinity_psu, pressure_dbar, extrapolate."""
    return place(port, **water).virtual_image_table(wd_mm, aperture_height_mm)


# --- planning and simulation --------------------------------------------------------------------

@contextlib.contextmanager
def _port_files(kwargs, *keys):
    """PortSpec objects among kwargs[keys] (load_port(), assemble().port) passed to the bindings as
    TOML files (they take a preset name or a path), removed afterwards."""
    with tempfile.TemporaryDirectory(prefix="porthole-port-") as tmp:
        for key in keys:
            spec = kwargs.get(key)
            if isinstance(spec, PortSpec):
                path = os.path.join(tmp, f"{key}.toml")
                with open(path, "w") as f:
                    f.write(spec.to_toml())
                kwargs[key] = path
        yield kwargs


_PORT_DOC = "port may also be a PortSpec (load_port(), assemble().port)."


@_wraps(_porthole.plan, "porthole.Plan", _PORT_DOC)
def plan(**kwargs) -> Plan:
    with _port_files(kwargs, "port"):
        return Plan(_porthole.plan(**kwargs))


@_wraps(_porthole.flat, "porthole.FlatAnalysis", _PORT_DOC)
def flat(**kwargs) -> FlatAnalysis:
    with _port_files(kwargs, "port"):
        return FlatAnalysis(_porthole.flat(**kwargs))


@_wraps(_porthole.simulate, "porthole.Simulation",
        "air_calibration may also be a Calibration (calibrate()'s result); " + _PORT_DOC)
def simulate(**kwargs) -> Simulation:
    if "air_calibration" in kwargs:
        kwargs["air_calibration"] = _plain(kwargs["air_calibration"])
    with _port_files(kwargs, "port"):
        return Simulation(_porthole.simulate(**kwargs))


# --- cameras and calibration ------------------------------------------------------------------

def port_shapes() -> list:
    """The port shapes, in the port list's order (ports/port.h): "dome", "flat", "cylinder" — the
    values of PortType."""
    return list(_porthole.port_shapes())


@_wraps(_porthole.camera_models, "list[porthole.Record]")
def camera_models():
    return [Record(m) for m in _porthole.camera_models()]


@_wraps(_porthole.project, "numpy.ndarray", "camera may also be a Calibration.")
def project(camera, points_in_cam, **kwargs) -> np.ndarray:
    return _porthole.project(_camera_dict(camera), np.asarray(points_in_cam, float), **kwargs)


@_wraps(_porthole.unproject, "numpy.ndarray", "camera may also be a Calibration.")
def unproject(camera, pixels, **kwargs) -> np.ndarray:
    return _porthole.unproject(_camera_dict(camera), np.asarray(pixels, float), **kwargs)


def _camera_dict(camera):
    if isinstance(camera, Calibration):
        return dict(camera.params, model=camera.model.value)
    return camera


@_wraps(_porthole.detect, "porthole.DetectionSet")
def detect(images, target, **kwargs) -> DetectionSet:
    if not isinstance(images, (str, os.PathLike)):
        images = [os.fspath(i) for i in images]
    return DetectionSet.from_dict(_porthole.detect(images, target, **kwargs))


@_wraps(_porthole.calibrate, "porthole.Calibration",
        "detections may be detect()'s DetectionSet, a list of Detections or of dicts.\n\n"
        "With port=... (a preset name, a port TOML file or a PortSpec) it is the refractive "
        "calibration of `porthole calibrate --port` (the lens behind the port, the port measured from "
        "the images) and returns a RefractiveCalibration; its keywords are calibrate_refractive()'s:\n\n"
        + _core_doc("calibrate_refractive"))
def calibrate(detections, target, *, port=None, **kwargs) -> Calibration:
    plain = _plain(detections if isinstance(detections, DetectionSet) else list(detections))
    return _calibrate(plain, target, port, kwargs)


def _calibrate(source, target, port, kwargs) -> Calibration:
    """calibrate() of detections (plain dicts) or of images to search (a path: calibrate_images()),
    each one library call (calib::CalibrateJob), its warnings emitted as the CLI prints them."""
    if port is None:
        c = Calibration.from_dict(_porthole.calibrate(source, target, **kwargs))
        for text in c.warnings:  # as the CLI prints them on stderr
            _warnings.warn(text, PortholeWarning, stacklevel=3)
        return c
    if "air_calibration" in kwargs:
        kwargs["air_calibration"] = _plain(kwargs["air_calibration"])
    if kwargs.get("air_detections") is not None:  # as detections: a DetectionSet or a list
        air = kwargs["air_detections"]
        kwargs["air_detections"] = _plain(air if isinstance(air, DetectionSet) else list(air))
    kwargs["port"] = port
    with _port_files(kwargs, "port"):
        d, estimated_port, said = _porthole.calibrate_refractive(source, target, **kwargs)
    c = RefractiveCalibration.from_dict(d, estimated_port, warnings=said)
    for text in c.warnings:  # the pitch's and the port's, as the CLI prints them on stderr
        _warnings.warn(text, PortholeWarning, stacklevel=3)
    return c


@_wraps(_porthole.calibrate_rig, "porthole.RigCalibration",
        "cameras: one entry per camera, each detect()'s DetectionSet or a list of Detections or of dicts; "
        "air_calibration: one Calibration or file per camera.")
def calibrate_rig(cameras, target, **kwargs) -> "RigCalibration":
    plain = [_plain(c if isinstance(c, DetectionSet) else list(c)) for c in cameras]
    if kwargs.get("air_calibration") is not None:
        air = kwargs["air_calibration"]
        kwargs["air_calibration"] = [_plain(a) for a in (air if isinstance(air, (list, tuple)) else [air])]
    if kwargs.get("air_detections") is not None:
        kwargs["air_detections"] = [_plain(c if isinstance(c, DetectionSet) else list(c))
                                    for c in kwargs["air_detections"]]
    d, estimated_ports = _porthole.calibrate_rig(plain, target, **kwargs)
    r = RigCalibration.from_dict(d, estimated_ports)
    for text in r.warnings:  # the job's, as the CLI prints them on stderr (each camera's repeat its pitch's)
        _warnings.warn(text, PortholeWarning, stacklevel=2)
    return r


@_wraps(_porthole.measure, "porthole.Measurement",
        "rig may be a RigCalibration; points may hold DetectionSet or Detections objects per camera.")
def measure(rig, points, **kwargs) -> "Measurement":
    if isinstance(rig, RigCalibration):
        rig = rig.to_dict()
    if not isinstance(points, (str, os.PathLike)):
        points = [_plain(c if isinstance(c, DetectionSet) else list(c)) if _is_camera_list(c) else tuple(c)
                  for c in points]
    r = Measurement.from_dict(_porthole.measure(rig, points, **kwargs))
    for text in r.warnings:
        _warnings.warn(text, PortholeWarning, stacklevel=2)
    if r.scale_bar is not None and not r.scale_bar.consistent:
        _warnings.warn(r.scale_bar.verdict, PortholeWarning, stacklevel=2)
    return r


@_wraps(_porthole.undistort, "porthole.Record", "The Record holds source, pinhole (fx_px, fy_px, cx_px, cy_px, "
        "centre_in_cam_mm), options, images and, behind a port, residual (per WD: rms_px, max_px, error_px).")
def undistort(calibration, images, out, **kwargs) -> Record:
    return Record(_porthole.undistort(calibration, images, out, **kwargs))


@_wraps(_porthole.plan_rig, "porthole.Record", "rig may be a RigCalibration. The Record holds rig, sigma_px, "
        "length_mm, sigma_holds, central_model and `ranges` (one row per range: range_mm, common_width_mm, "
        "common_height_mm, n_lengths, sigma_median_mm, sigma_p90_mm, central_abs_median_mm, ...); its attribute "
        "`warnings` (not in to_dict(), the CLI's JSON) the plausibility warnings of a described rig's camera, lens "
        "and port, emitted as PortholeWarning as the notes are.")
def plan_rig(**kwargs) -> Record:
    if isinstance(kwargs.get("rig"), RigCalibration):
        kwargs["rig"] = kwargs["rig"].to_dict()
    d = _porthole.plan_rig(**kwargs)
    r = Record(d["rig_plan"])
    object.__setattr__(r, "warnings", list(d["warnings"]))
    for text in r.warnings + list(r.notes):  # as the CLI prints them on stderr
        _warnings.warn(text, PortholeWarning, stacklevel=2)
    return r


def _is_camera_list(c) -> bool:
    """One camera's detections (a DetectionSet, or a list of Detections/dicts), not a point tuple."""
    if isinstance(c, DetectionSet):
        return True
    return isinstance(c, list) and len(c) > 0 and (isinstance(c[0], dict) or isinstance(c[0], Detections))


def calibrate_images(images, target: str, *, threads: int = 0, field=None, every: int = 0, max_frames: int = 0,
                     port=None, **calibrate_options) -> Calibration:
    """Detects `target` in the images (a folder, one image, a video or a list of files) and calibrates
    from what was found — `porthole calibrate --images`, the same library call (calib::CalibrateJob
    searches them itself). A video keeps 40 frames chosen automatically unless max_frames says otherwise (blurred ones out,
    the rest spread over the frame and the tilts). field: a coded target's field file (`--field`; 3-D
    fields too). The keywords are calibrate()'s (model, pixel_pitch_mm, free, reject_k, loss,
    target_free, centre_correction, port, ...)."""
    search = dict(calibrate_options, threads=threads, field=field, every=every, max_frames=max_frames)
    if isinstance(images, (str, os.PathLike)):
        return _calibrate(os.fspath(images), target, port, search)
    return _calibrate([], target, port, dict(search, image_files=[os.fspath(i) for i in images]))


@_wraps(_porthole.synthetic_detections, "list[porthole.Detections]")
def synthetic_detections(camera, **kwargs):
    return [Detections.from_dict(d) for d in _porthole.synthetic_detections(_camera_dict(camera), **kwargs)]


@_wraps(_porthole.compare, "porthole.Comparison", "a and b may be Calibration objects.")
def compare(a, b, **kwargs) -> Comparison:
    return Comparison(_porthole.compare(_plain(a), _plain(b), **kwargs))


def load_calibration(path) -> Calibration:
    """A calibration JSON file (`porthole calibrate --out`, or the paper's Table 6 as
    scripts/sample-data writes it) as a Calibration."""
    import json
    with open(os.fspath(path)) as f:
        return Calibration.from_dict(json.load(f))


@_wraps(_porthole.convert, "porthole.ConvertResult", "inputs may be one path or a list; port may also be a PortSpec.")
def convert(inputs, out, **kwargs) -> ConvertResult:
    inputs = [inputs] if isinstance(inputs, (str, os.PathLike)) else [os.fspath(i) for i in inputs]
    with _port_files(kwargs, "port"):
        return ConvertResult(_porthole.convert(inputs, os.fspath(out), **kwargs))


@_wraps(_porthole.render, "porthole.RenderResult | porthole.RenderSet",
        "port may also be a PortSpec, rig a RigCalibration (calibrate_rig()'s). One image returns a "
        "RenderResult; a set or a rig a RenderSet (its renders: one RenderedImage per image, with its "
        "ground truth; of(camera, medium) picks one camera's).")
def render(out, **kwargs) -> Union[RenderResult, RenderSet]:
    if isinstance(kwargs.get("rig"), RigCalibration):
        kwargs["rig"] = kwargs["rig"].to_dict()
    with _port_files(kwargs, "port"):
        d = _porthole.render(os.fspath(out), **kwargs)
    r = RenderSet(d) if "renders" in d else RenderResult(d)
    for text in r.warnings:  # the notes the CLI prints on stderr (the plausibility warnings are emitted already)
        if _IMPLAUSIBLE not in text:
            _warnings.warn(text, PortholeWarning, stacklevel=2)
    return r


# --- scans and fits ---------------------------------------------------------------------------

read_point_cloud = _porthole.read_point_cloud


@_wraps(_porthole.fit_sphere, "porthole.SphereFit")
def fit_sphere(points, **kwargs) -> SphereFit:
    return SphereFit.from_dict(_porthole.fit_sphere(_points(points), **kwargs))


@_wraps(_porthole.analyze_dome, "porthole.DomeFit")
def analyze_dome(outer_points, inner_points, **kwargs) -> DomeFit:
    return DomeFit.from_dict(_porthole.analyze_dome(_points(outer_points), _points(inner_points), **kwargs))


@_wraps(_porthole.assemble, "porthole.HousingAssembly", "outer and inner may be SphereFit results.")
def assemble(**kwargs) -> HousingAssembly:
    for key in ("outer", "inner"):
        if isinstance(kwargs.get(key), SphereFit):
            fit = kwargs[key]
            kwargs[key] = (*fit.center_mm.tolist(), fit.radius_mm)
    d = _porthole.assemble(**kwargs)
    port = d.pop("port")
    out = HousingAssembly(d)
    object.__setattr__(out, "port", port)
    return out


def _points(points):
    if isinstance(points, (str, os.PathLike)):
        return read_point_cloud(os.fspath(points))
    return np.asarray(points, float)


# --- report -----------------------------------------------------------------------------------

@_wraps(_porthole.report, "porthole.ReportSummary", "port and compare_port may also be PortSpec objects.")
def report(out, **kwargs) -> ReportSummary:
    for key in ("air_calibration", "water_calibration"):
        if key in kwargs and isinstance(kwargs[key], Calibration):
            kwargs[key] = kwargs[key].to_dict()
    with _port_files(kwargs, "port", "compare_port"):
        return ReportSummary(_porthole.report(os.fspath(out), **kwargs))


__all__ = [
    "__version__", "index", "media", "depth_to_pressure_dbar", "load_port", "presets", "place", "PortSpec",
    "PortSystem", "virtual_image_table", "plan", "flat", "simulate", "camera_models", "port_shapes", "project", "unproject",
    "detect", "calibrate", "calibrate_images", "calibrate_rig", "RigCalibration", "RigCamera", "measure", "plan_rig", "undistort", "Measurement", "MeasuredPoint", "MeasuredLength", "synthetic_detections", "compare", "load_calibration",
    "read_point_cloud", "fit_sphere", "analyze_dome", "assemble", "report", "HousingAssembly", "RayStatus",
    "PortType", "CameraModel",
    "Status", "Record", "Table", "PortholeWarning", "Plan", "FlatAnalysis", "Simulation", "Comparison", "ReportSummary",
    "Detections", "SkippedImage", "DetectionSet", "Calibration", "PortCalibration", "RefractiveCalibration",
    "VirtualImage", "VirtualImageTable",
    "PortFocal", "TraceResult", "SphereFit", "DomeFit", "Preset", "Medium", "DEFAULT_WD_MM",
    "convert", "ConvertResult", "render", "RenderResult", "RenderedImage", "RenderSet",
]
