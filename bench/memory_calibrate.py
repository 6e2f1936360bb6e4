#!/usr/bin/python3
"""Peak memory of a large calibration from images (docs/robustness.md, issue 10).

Renders N views of a 9 x 6 chessboard (25 mm squares) at the D300's 4288 x 2848 pixels through an
ideal 24 mm pinhole (OpenCV warpPerspective of a supersampled board, random poses at 0.6-1.0 m with
tilts up to 35 deg, JPEG quality 95), then runs `porthole calibrate --images DIR --out` under
/usr/bin/time -v and prints its peak resident memory, CPU and wall time, the images used and the
recovered focal length against the truth (so a run that silently failed is seen).

Usage: bench/memory_calibrate.py PORTHOLE_BINARY [--images 200] [--keep DIR]
"""
import argparse
import json
import math
import os
import re
import subprocess
import sys
import tempfile

import cv2
import numpy as np

WIDTH, HEIGHT, PITCH_MM, FOCAL_MM = 4288, 2848, 0.0055, 24.0
COLS, ROWS, SQUARE_MM = 9, 6, 25.0
PX_PER_MM = 8  # the board template's resolution


def board_template():
    """White margin of one square around (COLS+1) x (ROWS+1) squares; origin at the first inner corner."""
    w = int((COLS + 3) * SQUARE_MM * PX_PER_MM)
    h = int((ROWS + 3) * SQUARE_MM * PX_PER_MM)
    img = np.full((h, w), 255, np.uint8)
    s = int(SQUARE_MM * PX_PER_MM)
    for j in range(ROWS + 1):
        for i in range(COLS + 1):
            if (i + j) % 2 == 0:
                x0, y0 = (i + 1) * s, (j + 1) * s
                img[y0:y0 + s, x0:x0 + s] = 0
    # template pixel centre (u, v) <-> board mm: X = (u + 0.5) / PX_PER_MM - 2 squares
    mm_from_template = np.array([[1 / PX_PER_MM, 0, 0.5 / PX_PER_MM - 2 * SQUARE_MM],
                                 [0, 1 / PX_PER_MM, 0.5 / PX_PER_MM - 2 * SQUARE_MM],
                                 [0, 0, 1]])
    return img, mm_from_template


def rotation(rx, ry, rz):
    r, _ = cv2.Rodrigues(np.array([rx, ry, rz], float))
    return r


def render(n, out_dir, seed=1):
    rng = np.random.default_rng(seed)
    f_px = FOCAL_MM / PITCH_MM
    k = np.array([[f_px, 0, (WIDTH - 1) / 2], [0, f_px, (HEIGHT - 1) / 2], [0, 0, 1]])
    template, mm_from_template = board_template()
    centre = np.array([COLS - 1, ROWS - 1, 0]) * SQUARE_MM / 2
    written = 0
    while written < n:
        r = rotation(*np.radians(rng.uniform(-35, 35, 2)), np.radians(rng.uniform(-20, 20))) @ rotation(0, 0, 0)
        z = rng.uniform(600, 1000)
        # the board's centre somewhere in the middle 60 % of the frame
        u, v = rng.uniform(0.2, 0.8) * WIDTH, rng.uniform(0.2, 0.8) * HEIGHT
        t = z * np.array([(u - k[0, 2]) / f_px, (v - k[1, 2]) / f_px, 1.0]) - r @ centre
        image_from_mm = k @ np.column_stack([r[:, 0], r[:, 1], t])
        # the whole sheet (the board and its white margin) inside the frame
        a, b = -2 * SQUARE_MM, (COLS + 1) * SQUARE_MM
        c, d = -2 * SQUARE_MM, (ROWS + 1) * SQUARE_MM
        corners = np.array([[a, c, 1], [b, c, 1], [a, d, 1], [b, d, 1]]).T
        p = image_from_mm @ corners
        p = p[:2] / p[2]
        if p.min() < 50 or p[0].max() > WIDTH - 50 or p[1].max() > HEIGHT - 50:
            continue
        h = image_from_mm @ mm_from_template
        img = cv2.warpPerspective(template, h, (WIDTH, HEIGHT), flags=cv2.INTER_AREA,
                                  borderMode=cv2.BORDER_CONSTANT, borderValue=128)
        cv2.imwrite(os.path.join(out_dir, f"view{written:03d}.jpg"), img, [cv2.IMWRITE_JPEG_QUALITY, 95])
        written += 1
        if written % 20 == 0:
            print(f"rendered {written} of {n}", file=sys.stderr)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("porthole")
    ap.add_argument("--images", type=int, default=200)
    ap.add_argument("--keep", help="render into (or reuse) this folder instead of a temporary one")
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        d = a.keep or os.path.join(tmp, "views")
        os.makedirs(d, exist_ok=True)
        have = len([f for f in os.listdir(d) if f.endswith(".jpg")])
        if have < a.images:
            render(a.images, d)
        out = os.path.join(tmp, "cal.json")
        res = subprocess.run(["/usr/bin/time", "-v", a.porthole, "calibrate", "--images", d,
                              "--target", f"chessboard:{COLS}x{ROWS}:{SQUARE_MM:g}", "--pixel-pitch-mm",
                              str(PITCH_MM), "--out", out, "--quiet"], capture_output=True, text=True)
        if res.returncode != 0:
            sys.exit(f"calibrate failed: {res.stderr.strip().splitlines()[-1]}")
        peak_kb = int(re.search(r"Maximum resident set size \(kbytes\): (\d+)", res.stderr).group(1))
        user = float(re.search(r"User time \(seconds\): ([\d.]+)", res.stderr).group(1))
        sys_t = float(re.search(r"System time \(seconds\): ([\d.]+)", res.stderr).group(1))
        wall = re.search(r"Elapsed \(wall clock\) time \(h:mm:ss or m:ss\): ([\d:.]+)", res.stderr).group(1)
        cal = json.load(open(out))
        c = cal["camera"]["c_mm"]
        print(json.dumps({"images": a.images, "images_used": cal["n_images"],
                          "peak_rss_mb": round(peak_kb / 1024), "cpu_s": round(user + sys_t, 1),
                          "wall": wall, "c_mm": c, "c_true_mm": FOCAL_MM,
                          "rms_px": cal["rms_px"]}))


if __name__ == "__main__":
    main()
