"""Peer of bench_undistort.cc: cv2.remap (python3-opencv) on 2 threads with porthole's own map (read
from the raw float32 file the benchmark wrote), best of 5, and OpenCV's own undistortion map of the
same camera (cv2.initUndistortRectifyMap) against porthole's: the largest difference over the frame.
Prints one JSON line: seconds, map_diff_px."""
import json
import sys
import time

import cv2
import numpy as np

spec = json.loads(open(sys.argv[1]).read())
w, h, ch = spec["width"], spec["height"], spec["channels"]
m = np.fromfile(spec["map"], dtype=np.float32).reshape(h, w, 2)
rng = np.random.default_rng(1)
img = rng.integers(0, 256, size=(h, w, ch) if ch > 1 else (h, w), dtype=np.uint8)
cv2.setNumThreads(2)
best = 1e30
for _ in range(5):
    t0 = time.perf_counter()
    cv2.remap(img, m, None, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT)
    best = min(best, time.perf_counter() - t0)
k = np.array(spec["K"]).reshape(3, 3)
newk = np.array(spec["newK"]).reshape(3, 3)
ref, _ = cv2.initUndistortRectifyMap(k, np.array(spec["D"]), None, newk, (w, h), cv2.CV_32FC2)
ok = (m[..., 0] > 0) & (m[..., 0] < w - 1) & (m[..., 1] > 0) & (m[..., 1] < h - 1)
diff = float(np.abs(ref - m)[ok].max())
print(json.dumps({"seconds": best, "map_diff_px": diff}))
