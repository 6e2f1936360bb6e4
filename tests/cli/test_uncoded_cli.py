"""Proves `porthole detect --field` end to end on a real renderer's image: a coded sheet from
`porthole target-sheet` with plain (uncoded) dots added at the cells' centres and listed in the
field file under IDs above the profile's code count, drawn by librsvg (rsvg-convert) and seen in
perspective (OpenCV's warpPerspective): every uncoded dot is reported with its field ID where the
field puts it, a dot of the field left unprinted is counted as not found and given to nothing,
and the table counts them. A bad --field exits 2 with one line (issue 16)."""
import math
import re
import shutil

import numpy as np
import pytest

from conftest import run, run_bad
from test_coded_cli import DPI, read_field

SCALE = DPI / 25.4


def sheet_with_plain_dots(tmp_path, skip):
    """The default A4 coded:14:2.5 sheet, its printed IDs removed (they would sit in the plain dots'
    gaps), a plain dot at the centre of every cell of four targets; the field file lists every plain
    dot (IDs from 1001) but those whose index is in `skip` are not drawn."""
    svg = tmp_path / "sheet.svg"
    run("target-sheet", svg, "--radius-mm", 2.5)
    field = read_field(tmp_path / "sheet.field.txt")
    where = {(round(x, 3), round(y, 3)) for x, y, _ in field.values()}
    pitch = 20.0
    plain, drawn = {}, []
    for x, y in sorted(where):
        corners = [(round(x + dx, 3), round(y + dy, 3)) for dx in (0, pitch) for dy in (0, pitch)]
        if all(c in where for c in corners):
            k = len(plain)
            plain[1001 + k] = (x + pitch / 2, y + pitch / 2)
            if k not in skip:
                drawn.append(f'<circle cx="{x + pitch / 2}" cy="{y + pitch / 2}" r="2.5" fill="#000"/>')
    text = re.sub(r"<text[^>]*>[^<]*</text>", "", svg.read_text())
    svg.write_text(text.replace("</svg>", "\n".join(drawn) + "\n</svg>"))
    with open(tmp_path / "sheet.field.txt", "a") as f:
        for i, (x, y) in plain.items():
            f.write(f"{i} {x:.4f} {y:.4f} 0.0000\n")
    return svg, read_field(tmp_path / "sheet.field.txt"), plain


def test_detect_field_matches_uncoded_dots_in_a_real_render(tmp_path):
    if shutil.which("rsvg-convert") is None:
        pytest.fail("rsvg-convert missing: run scripts/install-deps (librsvg2-bin)")
    import cv2
    import subprocess

    missing = {3, 17}
    svg, field, plain = sheet_with_plain_dots(tmp_path, missing)
    images = tmp_path / "images"
    images.mkdir()
    flat = tmp_path / "flat.png"
    subprocess.run(["rsvg-convert", "-d", str(DPI), "-p", str(DPI), "-b", "white", str(svg), "-o", str(flat)],
                   check=True)
    img = cv2.imread(str(flat), cv2.IMREAD_GRAYSCALE)
    h, w = img.shape
    # A perspective view of the page: its corners pulled in unevenly (pixel centres at integers).
    src = np.float32([[0, 0], [w - 1, 0], [w - 1, h - 1], [0, h - 1]])
    dst = np.float32([[60, 40], [w - 140, 110], [w - 30, h - 60], [110, h - 170]])
    hom = cv2.getPerspectiveTransform(src, dst)
    cv2.imwrite(str(images / "view.png"), cv2.warpPerspective(img, hom, (w, h), flags=cv2.INTER_CUBIC,
                                                              borderValue=255))

    def image_of(x_mm, y_mm):  # rsvg's pixel u covers [u, u+1): its centre is at (u + 0.5) / SCALE mm
        p = hom @ np.array([x_mm * SCALE - 0.5, y_mm * SCALE - 0.5, 1.0])
        return p[:2] / p[2]

    res = run("detect", "--images", images, "--target", "coded:14:2.5", "--field", tmp_path / "sheet.field.txt")
    det = run("detect", "--images", images, "--target", "coded:14:2.5", "--field", tmp_path / "sheet.field.txt",
              "--json", "--quiet").json()
    found = dict(zip(det["images"][0]["ids"], det["images"][0]["points_px"]))
    uncoded = {i: p for i, p in found.items() if i > 516}
    errors = {i: math.dist(p, image_of(*field[i][:2])) for i, p in found.items()}
    worst = max(errors[i] for i in uncoded)
    print(res.out)
    print(f"{len(uncoded)} of {len(plain) - len(missing)} printed uncoded dots matched, worst {worst:.4f} px "
          f"from the field through the warp; {len(found) - len(uncoded)} coded targets")
    assert set(uncoded) == {1001 + k for k in range(len(plain)) if k not in missing}
    assert all(e < 0.15 for e in errors.values()), max(errors.values())
    assert f"uncoded dots: {len(uncoded)} matched of {len(plain)} in view; {len(missing)} not found" in res.out
    assert f"{len(uncoded)}/{len(plain)}" in res.out


def test_bad_field_is_one_line(tmp_path):
    (tmp_path / "x.png").write_bytes(b"")
    field = tmp_path / "f.txt"
    field.write_text("1 10 10 0\n1 20 20 0\n")
    line = run_bad("detect", "--images", tmp_path, "--target", "coded:14:2.5", "--field", field)
    assert line.startswith("porthole: error: --field"), line
    line = run_bad("detect", "--images", tmp_path, "--target", "coded:14:2.5", "--field", tmp_path / "none.txt")
    assert line.startswith("porthole: error: --field"), line
    field.write_text("1 10 10 0\n")
    line = run_bad("detect", "--images", tmp_path, "--target", "chessboard:9x6:25", "--field", field)
    assert line.startswith("porthole: error: --field"), line
