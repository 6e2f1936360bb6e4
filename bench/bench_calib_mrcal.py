#!/usr/bin/python3
"""The mrcal peer of bench_calib.cc: calibrates one camera with mrcal (Debian python3-mrcal,
LENSMODEL_OPENCV5) from a porthole detections set (porthole detect --json) and prints one JSON line:
seconds (seed + optimisation, in this process), rms_px (2-D, as OpenCV and porthole report it),
the intrinsics fx fy cx cy k1 k2 p1 p2 k3. Usage: bench_calib_mrcal.py DETECTIONS.json"""
import json
import sys
import time

import numpy as np
import mrcal


def main(path):
    d = json.load(open(path))
    kind, size, spacing = d["target"].split(":")[:3]
    if kind != "chessboard":
        raise SystemExit("mrcal peer: chessboard targets only")
    cols, rows = map(int, size.split("x"))
    spacing = float(spacing)
    images = d["images"]
    w, h = images[0]["width_px"], images[0]["height_px"]
    obs = np.full((len(images), rows, cols, 3), -1.0)
    for i, im in enumerate(images):
        for pid, (u, v) in zip(im["ids"], im["points_px"]):
            obs[i, pid // cols, pid % cols] = (u, v, 1.0)
    n_obs = int((obs[..., 2] > 0).sum())
    t0 = time.perf_counter()
    intrinsics, extrinsics, frames = mrcal.seed_stereographic(
        imagersizes=np.array([[w, h]]), focal_estimate=max(w, h),
        indices_frame_camera=np.array([[i, 0] for i in range(len(images))], dtype=np.int32),
        observations=obs, object_spacing=spacing)
    intrinsics = np.hstack([intrinsics[:, :4], np.zeros((1, 5))])
    common = dict(extrinsics_rt_fromref=extrinsics, frames_rt_toref=frames, points=None,
                  observations_board=obs,
                  indices_frame_camintrinsics_camextrinsics=np.array(
                      [[i, 0, -1] for i in range(len(images))], dtype=np.int32),
                  observations_point=None, indices_point_camintrinsics_camextrinsics=None,
                  lensmodel="LENSMODEL_OPENCV5", imagersizes=np.array([[w, h]], dtype=np.int32),
                  calibration_object_spacing=spacing, do_optimize_frames=True, do_optimize_calobject_warp=False,
                  do_apply_outlier_rejection=False, do_apply_regularization=False)
    mrcal.optimize(intrinsics, do_optimize_intrinsics_core=True,
                   do_optimize_intrinsics_distortions=False, **common)
    stats = mrcal.optimize(intrinsics, do_optimize_intrinsics_core=True,
                           do_optimize_intrinsics_distortions=True, **common)
    seconds = time.perf_counter() - t0
    x = stats["x"][: 2 * obs[..., 0].size]
    rms = float(np.sqrt(np.sum(x**2) / n_obs))
    print(json.dumps({"peer": "mrcal LENSMODEL_OPENCV5", "seconds": seconds, "rms_px": rms,
                      "intrinsics": dict(zip(["fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3"],
                                             map(float, intrinsics[0])))}))


if __name__ == "__main__":
    main(sys.argv[1])
