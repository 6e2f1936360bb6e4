#!/usr/bin/env python3
"""NumPy peer of porthole's batched tracer (bench_trace.cc, BM_TraceNumpyPeer).

A vectorised NumPy implementation of the same trace: rays (origin, unit direction) through a
sequence of refracting spheres, each bounded by an aperture half-space, with the vector form of
Snell's law, the same failure statuses (0 ok, 1 missed, 2 outside the aperture, 3 total internal
reflection) and the same rule that a failed ray is left where it stopped. It performs the same
IEEE operations in the same order as porthole's optics::Step, so the answers agree bit for bit.

Written to be as fast as NumPy goes on one core (it is the peer of a speed claim): structure of
arrays of shape (3, n) so that one call covers all three coordinates; every operation a ufunc
writing into preallocated work arrays (out=), selections done in place (np.copyto with where=)
rather than by np.where's new arrays, and the rays taken in slices whose work arrays stay in the
cache (the slice size is an argument: the benchmark measures whole arrays and slices). Nothing
loops over single rays in Python.

Usage: bench_trace_numpy.py SPEC.json
  SPEC: {"rays": "<file: float64 ox,oy,oz,dx,dy,dz arrays of n each>", "n": n,
         "surfaces": [{"center_mm": [x,y,z], "radius_mm": r, "aperture_point_mm": [x,y,z],
                       "aperture_normal": [x,y,z], "n_before": n1, "n_after": n2}, ...],
         "repeats": k, "chunk": rays per slice (default 32768; n or more: whole arrays),
         "out": "<file for the traced rays, same layout, then uint8 statuses>"}
Prints one JSON line: {"seconds": best of k traces, "seconds_all": [...], "cpu_seconds": best of
the k traces' process CPU times, "n": n, "numpy": ver}.
Only the trace is timed (not reading or writing files).
"""
import json
import sys
import time

import numpy as np

EPS = 1e-9


class Work:
    """Work arrays for slices of up to m rays, allocated once."""

    def __init__(self, m):
        self.m = m
        v = lambda: np.empty((3, m))  # noqa: E731
        s = lambda: np.empty(m)  # noqa: E731
        b = lambda: np.empty(m, dtype=bool)  # noqa: E731
        self.v1, self.v2, self.p, self.normal, self.d_new = v(), v(), v(), v(), v()
        self.b, self.nb, self.s1, self.sq, self.t, self.t1, self.q = s(), s(), s(), s(), s(), s(), s()
        self.real, self.mask, self.hit, self.ok = b(), b(), b(), b()
        self.st = np.empty(m, dtype=np.uint8)

    def view(self, m):
        """The same arrays cut to m rays (the last, shorter slice)."""
        if m == self.m:
            return self
        w = Work.__new__(Work)
        w.m = m
        for k, a in self.__dict__.items():
            if isinstance(a, np.ndarray):
                setattr(w, k, a[..., :m])
        return w


def dot(a, b, tmp, out):
    """out = a.x*b.x + a.y*b.y + a.z*b.z, summed in that order (as porthole's P3::dot)."""
    np.multiply(a, b, out=tmp)
    np.add(tmp[0], tmp[1], out=out)
    np.add(out, tmp[2], out=out)
    return out


def step_sphere(o, d, status, s, w):
    """One surface for every live ray of a slice, in place: o, d (3, m) and status (m,) are
    updated as porthole's optics::Step and the batched tracer do (a ray whose status is not 0 is
    left as it is)."""
    c = s["c"]
    r = s["radius_mm"]
    # Intersection: smallest root beyond EPS, the discriminant from the perpendicular vector.
    oc = np.subtract(o, c, out=w.v1)
    b = dot(oc, d, w.v2, w.b)
    perp = np.subtract(oc, np.multiply(d, b, out=w.v2), out=w.v2)
    disc = np.subtract(r * r, dot(perp, perp, w.v2, w.s1), out=w.s1)
    real = np.greater_equal(disc, 0.0, out=w.real)
    sq = np.sqrt(disc, out=w.sq, where=real)  # 0 where not real:
    np.copyto(sq, 0.0, where=np.logical_not(real, out=w.mask))
    nb = np.negative(b, out=w.nb)
    t1 = np.subtract(nb, sq, out=w.t1)
    t = np.add(nb, sq, out=w.t)
    np.copyto(t, t1, where=np.greater(t1, EPS, out=w.mask))
    hit = np.logical_and(real, np.greater(t, EPS, out=w.hit), out=w.hit)
    p = np.add(o, np.multiply(d, t, out=w.p), out=w.p)
    # Status, lowest precedence first: 3 total internal reflection, 2 outside the aperture,
    # 1 missed; 0 ok.
    st = w.st
    # Vector Snell's law at the unit normal (p - c) * (1 / r), turned to face the incoming ray.
    normal = np.multiply(np.subtract(p, c, out=w.normal), 1.0 / r, out=w.normal)
    dn = dot(normal, d, w.v2, w.s1)
    sign = w.q
    sign.fill(1.0)
    np.copyto(sign, -1.0, where=np.greater(dn, 0.0, out=w.mask))
    cos_i = np.multiply(np.negative(sign, out=w.t1), dn, out=w.t1)
    eta = s["n_before"] / s["n_after"]
    k = np.multiply(cos_i, cos_i, out=w.b)
    np.subtract(1.0, k, out=k)
    np.multiply(eta * eta, k, out=k)
    np.subtract(1.0, k, out=k)
    refracted = np.greater_equal(k, 0.0, out=w.ok)
    root = np.sqrt(k, out=w.sq, where=refracted)
    np.copyto(root, 0.0, where=np.logical_not(refracted, out=w.mask))
    # d_new = eta * d + ((eta * cos_i - root) * sign) * normal
    a = np.subtract(np.multiply(cos_i, eta, out=w.t1), root, out=w.t1)
    np.multiply(a, sign, out=a)
    d_new = np.add(np.multiply(d, eta, out=w.d_new), np.multiply(normal, a, out=w.v2),
                   out=w.d_new)
    st.fill(0)
    np.copyto(st, 3, where=np.logical_not(refracted, out=w.mask))
    if s["bounded"]:
        # Aperture: the half-space where the surface has glass.
        inside = np.greater_equal(
            dot(np.subtract(p, s["ap"], out=w.v1), s["an"], w.v2, w.s1), 0.0, out=w.mask)
        np.copyto(st, 2, where=np.logical_not(inside, out=w.mask))
    np.copyto(st, 1, where=np.logical_not(hit, out=w.mask))
    # Live rays only: the origin moves where the surface was hit, the direction where it refracted.
    live = np.equal(status, 0, out=w.real)
    np.copyto(o, p, where=np.logical_and(live, hit, out=w.mask))
    np.copyto(status, st, where=live)
    np.copyto(d, d_new, where=np.equal(status, 0, out=w.mask))


def prepare(surfaces):
    out = []
    for s in surfaces:
        an = np.asarray(s["aperture_normal"], dtype=np.float64)
        out.append(dict(s, c=np.asarray(s["center_mm"], dtype=np.float64)[:, None],
                        ap=np.asarray(s["aperture_point_mm"], dtype=np.float64)[:, None],
                        an=an[:, None], bounded=bool(np.any(an != 0))))
    return out


def trace_into(o, d, status, o0, d0, surfaces, chunk, work):
    """Traces the rays (o0, d0) in slices of `chunk` rays into o, d, status (preallocated, as
    porthole's output batch is)."""
    n = o0.shape[1]
    with np.errstate(invalid="ignore"):
        for i in range(0, n, chunk):
            j = min(n, i + chunk)
            w = work.view(j - i)
            oi, di, si = o[:, i:j], d[:, i:j], status[i:j]
            np.copyto(oi, o0[:, i:j])
            np.copyto(di, d0[:, i:j])
            si.fill(0)
            for s in surfaces:
                step_sphere(oi, di, si, s, w)


def main():
    spec = json.load(open(sys.argv[1]))
    n = spec["n"]
    a = np.fromfile(spec["rays"], dtype=np.float64, count=6 * n).reshape(6, n)
    o0, d0 = np.ascontiguousarray(a[:3]), np.ascontiguousarray(a[3:])
    surfaces = prepare(spec["surfaces"])
    chunk = min(n, spec.get("chunk", 32768))
    o, d, status = np.empty_like(o0), np.empty_like(d0), np.empty(n, dtype=np.uint8)
    work = Work(chunk)
    times, cpu_times = [], []
    for _ in range(spec.get("repeats", 3)):
        t0, c0 = time.perf_counter(), time.process_time()
        trace_into(o, d, status, o0, d0, surfaces, chunk, work)
        times.append(time.perf_counter() - t0)
        cpu_times.append(time.process_time() - c0)
    if spec.get("out"):
        with open(spec["out"], "wb") as f:
            np.concatenate([o, d]).astype(np.float64).tofile(f)
            status.tofile(f)
    print(json.dumps({"seconds": min(times), "seconds_all": times, "cpu_seconds": min(cpu_times),
                      "n": n, "numpy": np.__version__}))


if __name__ == "__main__":
    main()
