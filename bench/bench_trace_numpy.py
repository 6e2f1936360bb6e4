#!/usr/bin/env python3
"""NumPy peer of porthole's batched tracer (bench_trace.cc, BM_TraceNumpyPeer).

A vectorised NumPy implementation of the same trace: rays (origin, unit direction) through a
sequence of refracting spheres, each bounded by an aperture half-space, with the vector form of
Snell's law, the same failure statuses (0 ok, 1 missed, 2 outside the aperture, 3 total internal
reflection) and the same rule that a failed ray is left where it stopped. Every operation works on
arrays of rays (structure of arrays, shape (3, n), in cache-sized slices); nothing loops over
single rays in Python.

Usage: bench_trace_numpy.py SPEC.json
  SPEC: {"rays": "<file: float64 ox,oy,oz,dx,dy,dz arrays of n each>", "n": n,
         "surfaces": [{"center_mm": [x,y,z], "radius_mm": r, "aperture_point_mm": [x,y,z],
                       "aperture_normal": [x,y,z], "n_before": n1, "n_after": n2}, ...],
         "repeats": k, "chunk": rays per slice (default 32768; n or more: whole arrays),
         "out": "<file for the traced rays, same layout, then uint8 statuses>"}
Prints one JSON line: {"seconds": best of k traces, "seconds_all": [...], "n": n, "numpy": ver}.
Only the trace is timed (not reading or writing files).
"""
import json
import sys
import time

import numpy as np

EPS = 1e-9


def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def step_sphere(o, d, s):
    """One surface for every ray: returns (o, d, status) as porthole's optics::Step does."""
    c = np.asarray(s["center_mm"], dtype=np.float64)[:, None]
    r = s["radius_mm"]
    # Intersection: smallest root beyond EPS, the discriminant from the perpendicular vector.
    oc = o - c
    b = dot(oc, d)
    perp = oc - b * d
    disc = r * r - dot(perp, perp)
    real = disc >= 0
    sq = np.sqrt(np.where(real, disc, 0.0))
    t1 = -b - sq
    t = np.where(t1 > EPS, t1, -b + sq)
    hit = real & (t > EPS)
    p = o + t * d
    # Aperture: the half-space where the surface has glass.
    an = np.asarray(s["aperture_normal"], dtype=np.float64)[:, None]
    if np.any(an != 0):
        ap = np.asarray(s["aperture_point_mm"], dtype=np.float64)[:, None]
        inside = dot(p - ap, an) >= 0
    else:
        inside = np.ones_like(hit)
    # Vector Snell's law at the unit normal (p - c) / r, turned to face the incoming ray.
    normal = (p - c) * (1.0 / r)
    dn = dot(normal, d)
    sign = np.where(dn > 0, -1.0, 1.0)
    cos_i = -sign * dn
    eta = s["n_before"] / s["n_after"]
    k = 1.0 - eta * eta * (1.0 - cos_i * cos_i)
    refracted = k >= 0
    root = np.sqrt(np.where(refracted, k, 0.0))
    d_new = eta * d + ((eta * cos_i - root) * sign) * normal
    status = np.where(~hit, 1, np.where(~inside, 2, np.where(~refracted, 3, 0))).astype(np.uint8)
    o_out = np.where(hit, p, o)
    d_out = np.where(status == 0, d_new, d)
    return o_out, d_out, status


def trace(o, d, surfaces):
    status = np.zeros(o.shape[1], dtype=np.uint8)
    for s in surfaces:
        o2, d2, st = step_sphere(o, d, s)
        live = status == 0
        o = np.where(live, o2, o)
        d = np.where(live, d2, d)
        status = np.where(live, st, status)
    return o, d, status


def trace_chunked(o, d, surfaces, chunk):
    """trace() over slices of `chunk` rays, so that NumPy's temporaries stay in the cache (with
    32768 rays per slice NumPy runs faster than on whole 1 M-ray arrays: the benchmark measures
    both)."""
    n = o.shape[1]
    if chunk >= n:
        return trace(o, d, surfaces)
    o_out, d_out = np.empty_like(o), np.empty_like(d)
    status = np.empty(n, dtype=np.uint8)
    for i in range(0, n, chunk):
        j = min(n, i + chunk)
        o_out[:, i:j], d_out[:, i:j], status[i:j] = trace(o[:, i:j], d[:, i:j], surfaces)
    return o_out, d_out, status


def main():
    spec = json.load(open(sys.argv[1]))
    n = spec["n"]
    a = np.fromfile(spec["rays"], dtype=np.float64, count=6 * n).reshape(6, n)
    o0, d0 = np.ascontiguousarray(a[:3]), np.ascontiguousarray(a[3:])
    times = []
    for _ in range(spec.get("repeats", 3)):
        t0 = time.perf_counter()
        o, d, status = trace_chunked(o0, d0, spec["surfaces"], spec.get("chunk", 32768))
        times.append(time.perf_counter() - t0)
    if spec.get("out"):
        with open(spec["out"], "wb") as f:
            np.concatenate([o, d]).astype(np.float64).tofile(f)
            status.tofile(f)
    print(json.dumps({"seconds": min(times), "seconds_all": times, "n": n,
                      "numpy": np.__version__}))


if __name__ == "__main__":
    main()
