"""Calibration from video (issue 28): `--images` takes a video file or a single image as well as a
folder. A video made with the real `ffmpeg` (H.264) from 60 frames rendered by `porthole render --set`
(the D300 + 24 mm behind the NI320 dome, in water), 10 of them blurred by a Gaussian of 2.5 px:
the automatic choice leaves out the blurred frames and calibrates to the same c as the 60 still
images within sigma; every frame is named by its index and time."""
import json
import re
import shutil
import subprocess

import pytest

from conftest import run, run_bad

TARGET = "chessboard:9x6:40"
PITCH = ["--pixel-pitch-mm", "0.029"]
FPS = 30
BLURRED = set(range(3, 60, 6))  # frames 3, 9, ..., 57


@pytest.fixture(scope="module")
def clip(tmp_path_factory):
    import cv2  # Debian's python3-opencv: blurs the frames; ffmpeg encodes them

    assert shutil.which("ffmpeg"), "ffmpeg is missing: scripts/install-deps installs it"
    d = tmp_path_factory.mktemp("video")
    run("render", "--set", 60, "--out", d / "set", "--spp", 4, *PITCH, "--f-number", "inf", "--quiet")
    frames = d / "frames"
    frames.mkdir()
    for k in range(60):
        img = cv2.imread(str(d / "set" / "water" / f"pose_{k:03d}.png"))
        if k in BLURRED:
            img = cv2.GaussianBlur(img, (0, 0), 2.5)
        cv2.imwrite(str(frames / f"{k:03d}.png"), img)
    # H.264 needs even sides: the 813 x 540 frames are padded by one column (right, black).
    subprocess.run(["ffmpeg", "-loglevel", "error", "-framerate", str(FPS), "-i", str(frames / "%03d.png"),
                    "-c:v", "libx264", "-crf", "12", "-pix_fmt", "yuv420p", "-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2",
                    str(d / "clip.mp4")], check=True)
    return d


def test_video_calibrates_to_the_stills_c_without_the_blurred_frames(clip):
    stills = run("calibrate", "--images", clip / "set" / "water", "--target", TARGET, *PITCH, "--json",
                 "--quiet").json()
    video = run("calibrate", "--images", clip / "clip.mp4", "--target", TARGET, *PITCH, "--json", "--quiet").json()
    src = video["images_source"]
    kept = {f["frame_index"] for f in src["frames"]}
    print(f"video: {src['searched']} frames searched, target in {src['found']}, {src['blurred']} blurred left out, "
          f"{src['kept']} kept ({src['cells_covered']}/{src['cells']} cells, {src['tilt_classes']}/9 tilts); "
          f"c {video['camera']['c_mm']:.4f} +- {video['sigma']['c_mm']:.4f} mm, stills "
          f"{stills['camera']['c_mm']:.4f} +- {stills['sigma']['c_mm']:.4f} mm")
    assert src["kind"] == "video" and src["frames_in_source"] == 60 and src["fps"] == pytest.approx(FPS)
    assert src["searched"] == 60 and src["found"] == 60
    assert src["blurred"] == 10 and not kept & BLURRED  # every blurred frame, and only those, left out
    assert src["kept"] == 40 == video["n_images"] == len(kept)  # the default for a video: 40 frames
    assert src["cells_covered"] == src["cells"] and src["tilt_classes"] >= 5
    blurred = [s for s in video["skipped"] if s["reason"].startswith("blurred")]
    assert sorted(int(s["image"][1:7]) for s in blurred) == sorted(BLURRED)
    read = [float(re.search(r"blurred by ([0-9.]+) px", s["reason"]).group(1)) for s in blurred]
    print(f"blurred frames read as {min(read):.2f}-{max(read):.2f} px")
    assert 1.5 < min(read) and max(read) < 2.5
    for f in src["frames"]:  # each frame named by its index, with its time
        assert f["image"] == f"f{f['frame_index']:06d}"
        assert f["time_s"] == pytest.approx(f["frame_index"] / FPS, abs=1e-6)
        assert f["blur_px"] < 0.8
    assert {im["image"] for im in video["images"]} == {f["image"] for f in src["frames"]}
    assert abs(video["camera"]["c_mm"] - stills["camera"]["c_mm"]) < video["sigma"]["c_mm"]
    # Fewer frames on request (--max-frames), every other frame searched (--every).
    few = run("calibrate", "--images", clip / "clip.mp4", "--target", TARGET, *PITCH, "--max-frames", 15, "--every",
              2, "--json", "--quiet").json()
    assert few["images_source"]["searched"] == 30 and few["n_images"] == 15
    assert all(f["frame_index"] % 2 == 0 for f in few["images_source"]["frames"])


def test_detect_names_frames_by_index_and_time(clip):
    r = run("detect", "--images", clip / "clip.mp4", "--target", TARGET, "--every", 10)
    assert "clip.mp4: video, 60 frames at 30 fps; 6 searched (every 10th), the target in 6" in r.out
    assert "f000030 (1.000 s)" in r.out
    assert "searching every 10th frame" in r.err
    j = run("detect", "--images", clip / "clip.mp4", "--target", TARGET, "--every", 10, "--json").json()
    assert [d["frame_index"] for d in j["images"]] == [0, 10, 20, 30, 40, 50]
    assert [d["time_s"] for d in j["images"]] == pytest.approx([0, 1 / 3, 2 / 3, 1, 4 / 3, 5 / 3])
    assert j["source"]["kind"] == "video" and j["source"]["every"] == 10
    # --out-dir writes one file per frame, which calibrate reads back with the frame's index and time.
    run("detect", "--images", clip / "clip.mp4", "--target", TARGET, "--every", 10, "--out-dir", clip / "det",
        "--quiet")
    one = json.loads((clip / "det" / "f000020.json").read_text())
    assert one["frame_index"] == 20 and one["time_s"] == pytest.approx(2 / 3)
    # Every 3rd frame: half of those searched are blurred (3, 9, ..., 57); all 10 still left out (a
    # median-based rule kept one: the median sat among the blurred frames).
    h = run("detect", "--images", clip / "clip.mp4", "--target", TARGET, "--every", 3, "--max-frames", 5,
            "--json").json()
    assert h["source"]["searched"] == 20 and h["source"]["blurred"] == 10
    assert not {d["frame_index"] for d in h["images"]} & BLURRED and len(h["images"]) == 5
    # One image.
    k = run("detect", "--images", clip / "set" / "water" / "pose_007.png", "--target", TARGET, "--json").json()
    assert [d["image"] for d in k["images"]] == ["pose_007.png"] and k["source"]["kind"] == "image"


def test_bad_video_input_is_one_line_and_exit_2(clip):
    (clip / "notes.txt").write_text("not a video\n")
    line = run_bad("detect", "--images", clip / "notes.txt", "--target", TARGET)
    assert "--images" in line and "not a directory, an image" in line and "video" in line
    line = run_bad("calibrate", "--images", clip / "missing.mp4", "--target", TARGET, *PITCH)
    assert "--images" in line and "no such file or directory" in line
    assert "--every" in run_bad("detect", "--images", clip / "clip.mp4", "--target", TARGET, "--every", 0)
    assert "--max-frames" in run_bad("calibrate", "--images", clip / "clip.mp4", "--target", TARGET, *PITCH,
                                     "--max-frames", -3)


def test_undistort_a_video(clip, tmp_path):
    """`undistort --images clip.mp4`: every N-th frame remapped with the calibration made from the same
    video, written as images/f<index>.png with its index and time in undistort.json; the board's
    corners in the output frames lie on one homography (a pinhole sees a plane so) within 0.1 px RMS."""
    import cv2
    import numpy as np

    run("calibrate", "--images", clip / "clip.mp4", "--target", TARGET, *PITCH, "--out", tmp_path / "cal.json",
        "--quiet")
    s = run("undistort", "--calibration", tmp_path / "cal.json", "--images", clip / "clip.mp4", "--every", 20,
            "--out", tmp_path / "u", "--json").json()
    v = s["video"]
    assert [f["frame_index"] for f in v["frames"]] == [0, 20, 40]
    assert [f["time_s"] for f in v["frames"]] == pytest.approx([0, 20 / FPS, 40 / FPS])
    assert s["images"] == ["images/f000000.png", "images/f000020.png", "images/f000040.png"]
    det = run("detect", "--images", tmp_path / "u" / "images", "--target", TARGET, "--json").json()["images"]
    assert len(det) == 3
    rms = []
    for d in det:
        ids = np.array(d["ids"])
        obj = np.stack([(ids % 9) * 40.0, (ids // 9) * 40.0], axis=1)
        img = np.array(d["points_px"])
        h, _ = cv2.findHomography(obj, img, 0)
        p = cv2.perspectiveTransform(obj.reshape(-1, 1, 2), h).reshape(-1, 2)
        rms.append(float(np.sqrt(np.mean(np.sum((p - img) ** 2, axis=1)))))
    print("undistorted video frames: homography RMS", [round(r, 4) for r in rms], "px")
    assert max(rms) < 0.1
