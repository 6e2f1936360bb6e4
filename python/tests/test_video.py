"""Proves Python reads a video as `porthole detect` and `calibrate --images` do (issue 28):
detect(video) names each frame by its index and time, every= searches every N-th frame, and
calibrate_images(video) keeps the frames chosen automatically (max_frames) and matches the CLI's
calibration of the same video."""
import pytest

import porthole
from test_notebook import cli_json

cv2 = pytest.importorskip("cv2")  # Debian's python3-opencv writes the video (MJPG)
np = pytest.importorskip("numpy")


@pytest.fixture(scope="module")
def video(tmp_path_factory):
    """16 frames of 800 x 600 px at 8 fps: a 9 x 6 chessboard (40 px squares) seen at various tilts."""
    d = tmp_path_factory.mktemp("video")
    path = d / "clip.avi"
    w = cv2.VideoWriter(str(path), cv2.CAP_FFMPEG, cv2.VideoWriter_fourcc(*"MJPG"), 8, (800, 600), False)
    assert w.isOpened()
    board = np.kron((np.indices((7, 10)).sum(axis=0) % 2) * 195 + 30, np.ones((40, 40))).astype(np.uint8)
    board = cv2.copyMakeBorder(board, 40, 40, 40, 40, cv2.BORDER_CONSTANT, value=225)
    h, wd = board.shape
    for k in range(16):
        a, b = 0.25 * np.sin(k), 0.25 * np.cos(1.3 * k)
        src = np.float32([[0, 0], [wd, 0], [wd, h], [0, h]])
        dst = np.float32([[150 + 40 * a, 100 + 30 * b], [650 - 40 * a, 100 - 30 * b],
                          [650 + 40 * a, 500 + 30 * b], [150 - 40 * a, 500 - 30 * b]]) + np.float32([10 * (k % 5), 8 * (k % 3)])
        img = cv2.warpPerspective(board, cv2.getPerspectiveTransform(src, dst), (800, 600), borderValue=225)
        w.write(img)
    w.release()
    return path


def test_detect_names_frames_by_index_and_time(video):
    s = porthole.detect(video, "chessboard:9x6:40", every=3)
    assert [d.frame_index for d in s.images] == [0, 3, 6, 9, 12, 15]
    assert [d.image for d in s.images] == ["f000000", "f000003", "f000006", "f000009", "f000012", "f000015"]
    assert [d.time_s for d in s.images] == pytest.approx([k / 8 for k in (0, 3, 6, 9, 12, 15)])
    assert s.source["kind"] == "video" and s.source["searched"] == 6 and s.source["fps"] == 8
    assert all(d.blur_px < 1 for d in s.images)
    # The same as the CLI's --json.
    cli = cli_json("detect", "--images", str(video), "--target", "chessboard:9x6:40", "--every", "3", "--json")
    assert [d["points_px"] for d in cli["images"]] == [d.to_dict()["points_px"] for d in s.images]


def test_calibrate_images_from_a_video_keeps_the_chosen_frames(video):
    cal = porthole.calibrate_images(video, "chessboard:9x6:40", max_frames=10)
    cli = cli_json("calibrate", "--images", str(video), "--target", "chessboard:9x6:40", "--max-frames", "10",
                   "--json", "--quiet")
    assert cal.n_images == 10 == cli["n_images"]
    assert cal.params["c_mm"] == pytest.approx(cli["camera"]["c_mm"], rel=1e-9)
    with pytest.raises(ValueError, match="every"):
        porthole.detect(video, "chessboard:9x6:40", every=-1)
