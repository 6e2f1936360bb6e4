#!/usr/bin/python3
"""Writes the fuzz-regression corpus (tests/fuzz/<kind>/...): valid seeds, the reproducers of issue 10,
hand-made hostile files and deterministic mutants of the seeds. Run once to regenerate; the files are
checked in, and findings of `make fuzz` are added by hand beside them (docs/robustness.md)."""
import json
import os
import random
import struct
import zlib

HERE = os.path.dirname(os.path.abspath(__file__))
RNG = random.Random(20261123)


def put(kind, name, data):
    d = os.path.join(HERE, kind)
    os.makedirs(d, exist_ok=True)
    with open(os.path.join(d, name), "wb") as f:
        f.write(data if isinstance(data, bytes) else data.encode())


def mutants(kind, stem, ext, seed, n):
    """n deterministic mutants: byte flips, truncations, duplicated and deleted ranges, inserted digits."""
    for k in range(n):
        b = bytearray(seed)
        op = k % 5
        if op == 0:
            for _ in range(1 + RNG.randrange(4)):
                b[RNG.randrange(len(b))] = RNG.randrange(256)
        elif op == 1:
            b = b[: RNG.randrange(len(b))]
        elif op == 2:
            i = RNG.randrange(len(b))
            j = min(len(b), i + 1 + RNG.randrange(64))
            b = b[:j] + b[i:j] * (1 + RNG.randrange(8)) + b[j:]
        elif op == 3:
            i = RNG.randrange(len(b))
            del b[i : i + 1 + RNG.randrange(32)]
        else:
            i = RNG.randrange(len(b))
            b[i:i] = RNG.choice([b"9999999999999", b"-1", b"1e308", b"nan", b"inf", b"\x00", b"\n", b'"', b"["])
        put(kind, f"mut-{stem}-{k:02d}{ext}", bytes(b))


def read(path):
    with open(os.path.join(HERE, "..", "..", path), "rb") as f:
        return f.read()


# --- TOML: port, camera, lens -----------------------------------------------------------------
port = read("presets/ports/nimar-ni320.toml")
flat = read("presets/ports/flat-acrylic-10mm.toml")
camera = read("presets/cameras/nikon-d300.toml")
lens = read("presets/lenses/nikkor-24mm-f2.8d.toml")
put("port", "valid-dome.toml", port)
put("port", "valid-flat.toml", flat)
put("port", "repro-deep-dotted-key.toml", "[" + "a." * 50000 + "a]\nx = 1\n")
put("port", "deep-dotted-assignment.toml", "a" + ".a" * 50000 + " = 1\n")
put("port", "deep-inline-tables.toml", "x = " + "{a = " * 20000 + "1" + "}" * 20000 + "\n")
put("port", "deep-arrays.toml", "x = " + "[" * 50000 + "]" * 50000 + "\n")
put("port", "repro-injection.toml", port.replace(b'name = "nimar-ni320"', b'name = "a\\" ; system \\"touch FILE\\" ; print \\""'))
put("port", "newline-key.toml", port + b'\n"a\\nporthole: error: forged second line" = 1\n')
put("port", "long-key.toml", port + b"\n" + b"k" * 200000 + b" = 1\n")
put("port", "latin1-name.toml", port.replace(b'name = "nimar-ni320"', b'name = "d\xf4me"'))
put("port", "nul-bytes.toml", port.replace(b"type", b"ty\x00pe"))
put("port", "unterminated-string.toml", b'name = "abc\ntype = "dome"\n')
put("port", "huge-numbers.toml", port.replace(b"83.4", b"1e308").replace(b"75.7", b"-1e308"))
put("port", "empty.toml", b"")
mutants("port", "dome", ".toml", port, 30)
put("camera", "valid.toml", camera)
put("camera", "repro-width-overflow.toml", camera.replace(b"width_px = 4288", b"width_px = 4294967936"))
put("camera", "width-fraction.toml", camera.replace(b"width_px = 4288", b"width_px = 4288.7"))
put("camera", "width-string.toml", camera.replace(b"width_px = 4288", b'width_px = "4288"'))
put("camera", "pitch-zero.toml", camera.replace(b"0.0055", b"0"))
mutants("camera", "d300", ".toml", camera, 15)
put("lens", "valid.toml", lens)
put("lens", "pupil-not-array.toml", lens.replace(b"pupil = [", b"pupil = 3\nxx = [", 1))
put("lens", "deep-pupil.toml", lens + b"\nq = " + b"[" * 3000 + b"]" * 3000 + b"\n")
mutants("lens", "24mm", ".toml", lens, 15)

# --- point clouds --------------------------------------------------------------------------------
pts = [(83.4 * x, 83.4 * y, 83.4 * z) for x, y, z in
       [(0, 0, 1), (1, 0, 0), (0, 1, 0), (-1, 0, 0), (0, -1, 0), (0.6, 0, 0.8), (0, 0.6, 0.8), (-0.6, 0, 0.8),
        (0, -0.6, 0.8), (0.48, 0.64, 0.6), (-0.48, 0.64, 0.6), (0.48, -0.64, 0.6)]]
ply_ascii = ("ply\nformat ascii 1.0\nelement vertex %d\nproperty float x\nproperty float y\nproperty float z\n"
             "end_header\n" % len(pts) + "".join("%g %g %g\n" % p for p in pts)).encode()
ply_bin = (b"ply\nformat binary_little_endian 1.0\nelement vertex %d\nproperty float x\nproperty float y\n"
           b"property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n" % len(pts)
           + b"".join(struct.pack("<3f", *p) for p in pts) + struct.pack("<B3i", 3, 0, 1, 2))
put("ply", "valid-ascii.ply", ply_ascii)
put("ply", "valid-binary.ply", ply_bin)
put("ply", "repro-extra-element-1e12.ply",
    ply_bin.replace(b"element face 1\n", b"element face 1000000000000\n"))
put("ply", "repro-bad-alloc-126-bytes.ply",
    b"ply\nformat binary_little_endian 1.0\nelement vertex 1000000000000\nproperty double x\n"
    b"property double y\nproperty double z\nend_header\n")
put("ply", "element-without-properties.ply",
    ply_bin.replace(b"element face 1\n", b"element nothing 1000000000000\nelement face 1\n"))
put("ply", "ascii-huge-count.ply", ply_ascii.replace(b"element vertex 12", b"element vertex 999999999999"))
put("ply", "list-count-huge.ply", ply_bin[:-13] + struct.pack("<B", 255) + b"\x00" * 8)
put("ply", "long-line.ply", b"ply\nformat ascii 1.0\ncomment " + b"x" * 200000 + b"\nend_header\n")
put("ply", "big-endian-truncated.ply", ply_bin.replace(b"binary_little_endian", b"binary_big_endian")[:-20])
mutants("ply", "ascii", ".ply", ply_ascii, 20)
mutants("ply", "binary", ".ply", ply_bin, 20)

stl_ascii = ("solid s\n" + "".join(
    "facet normal 0 0 1\nouter loop\n" + "".join("vertex %g %g %g\n" % pts[(i + k) % len(pts)] for k in range(3))
    + "endloop\nendfacet\n" for i in range(0, 12, 3)) + "endsolid s\n").encode()
stl_bin = b"binary stl".ljust(80, b" ") + struct.pack("<I", 4) + b"".join(
    struct.pack("<3f", 0, 0, 1) + b"".join(struct.pack("<3f", *pts[(i + k) % 12]) for k in range(3)) + b"\0\0"
    for i in range(0, 12, 3))
put("stl", "valid-ascii.stl", stl_ascii)
put("stl", "valid-binary.stl", stl_bin)
put("stl", "binary-count-4e9.stl", stl_bin[:80] + struct.pack("<I", 0xFFFFFFFF) + stl_bin[84:])
put("stl", "solid-but-binary.stl", b"solid" + stl_bin[5:])
mutants("stl", "ascii", ".stl", stl_ascii, 15)
mutants("stl", "binary", ".stl", stl_bin, 15)

obj = ("# sphere points\n" + "".join("v %g %g %g\n" % p for p in pts) + "f 1 2 3\n").encode()
put("obj", "valid.obj", obj)
put("obj", "v-short.obj", obj + b"v 1 2\n")
mutants("obj", "sphere", ".obj", obj, 15)
xyz = "".join("%g %g %g\n" % p for p in pts).encode()
csv = ("x,y,z\n" + "".join("%g,%g,%g\n" % p for p in pts)).encode()
put("xyz", "valid.xyz", xyz)
put("xyz", "valid.csv", csv)
put("xyz", "one-long-line.xyz", b"1 " * 100000)
put("xyz", "nan.xyz", xyz + b"nan 1 2\n")
mutants("xyz", "sphere", ".xyz", xyz, 10)
mutants("xyz", "sphere", ".csv", csv, 10)

# --- calibrations: porthole JSON and OpenCV YAML ----------------------------------------------------
cal = {"camera": {"c_mm": 24.5, "x0_mm": 0.01, "y0_mm": -0.02, "K1": 1.8e-4, "K2": -3e-7},
       "sigma": {"c_mm": 0.01, "x0_mm": 0.005, "y0_mm": 0.005, "K1": 1e-6, "K2": 1e-9},
       "sensor": {"width_px": 4288, "height_px": 2848, "pixel_pitch_mm": 0.0055}}
calj = json.dumps(cal, indent=1).encode()
put("calib_json", "valid.json", calj)
put("calib_json", "repro-width-overflow.json", calj.replace(b'"width_px": 4288', b'"width_px": 4294967936'))
put("calib_json", "deep-nesting.json", b"[" * 100000 + b"]" * 100000)
put("calib_json", "camera-string.json", calj.replace(b"24.5", b'"24.5"'))
put("calib_json", "covariance-ragged.json", calj[:-2] + b',"covariance": {"parameters": ["c_mm", "K1"], "matrix": [1, [2, 3]]}}')
put("calib_json", "fixed-not-strings.json", calj[:-2] + b',"fixed": [1, 2]}')
put("calib_json", "not-json.json", b"\xff\xfe{garbage")
mutants("calib_json", "cal", ".json", calj, 25)
yaml = (b"%YAML:1.0\n---\nimage_width: 4288\nimage_height: 2848\ncamera_matrix: !!opencv-matrix\n   rows: 3\n"
        b"   cols: 3\n   dt: d\n   data: [ 4454.5, 0., 2143.5, 0., 4454.5, 1423.5, 0., 0., 1. ]\n"
        b"distortion_coefficients: !!opencv-matrix\n   rows: 1\n   cols: 5\n   dt: d\n"
        b"   data: [ -0.1, 0.05, 0.0001, -0.0002, 0. ]\n")
put("yaml", "valid.yml", yaml)
put("yaml", "repro-regex-recursion.yml", b"camera_matrix:" + b" " * 100000 + b"\n")
put("yaml", "long-data.yml", yaml.replace(b"data: [ -0.1", b"data: [ " + b"0.1, " * 20000 + b"-0.1"))
put("yaml", "width-overflow.yml", yaml.replace(b"4288", b"99999999999999999999"))
put("yaml", "no-close-bracket.yml", yaml.replace(b"0., 0., 1. ]", b"0., 0., 1. " + b"7" * 100000))
mutants("yaml", "cv", ".yml", yaml, 20)

# --- detections ------------------------------------------------------------------------------------
det = {"image": "a.jpg", "target": "chessboard:4x3:25", "width_px": 640, "height_px": 480,
       "ids": list(range(12)), "points_px": [[100 + 50 * (i % 4), 100 + 50 * (i // 4)] for i in range(12)]}
detj = json.dumps({"target": "chessboard:4x3:25", "images": [det] * 3, "skipped": []}).encode()
put("detections", "valid-set.json", detj)
put("detections", "width-overflow.json", detj.replace(b'"width_px": 640', b'"width_px": 4294967936'))
put("detections", "images-string.json", b'{"target": "chessboard:4x3:25", "images": "abc"}')
put("detections", "target-number.json", b'{"target": 5, "images": []}')
put("detections", "target-huge.json", b'{"target": "chessboard:99999999999x3:25", "images": []}')
put("detections", "points-nan.json", detj.replace(b"[100, 100]", b"[1e999, 100]"))
mutants("detections", "set", ".json", detj, 20)


# --- images ----------------------------------------------------------------------------------------
def png(w, h, rows=None, bit_depth=8):
    def chunk(t, d):
        return struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d) & 0xFFFFFFFF)
    raw = rows if rows is not None else b"".join(b"\0" + bytes(w) for _ in range(min(h, 4)))
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, bit_depth, 0, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))


board = b"".join(b"\0" + bytes(255 if ((x // 20) + (y // 20)) % 2 else 0 for x in range(120)) for y in range(100))
put("images", "valid-board.png", png(120, 100, board))
put("images", "repro-huge-dims.png", png(20000, 20000))
put("images", "huge-width.png", png(2000000000, 1))
put("images", "zero-dims.png", png(0, 0))
put("images", "truncated.png", png(120, 100, board)[:200])
put("images", "jpeg-huge-sof.jpg", b"\xff\xd8\xff\xc0\x00\x11\x08\xff\xff\xff\xff\x01\x01\x11\x00" + b"\0" * 40)
put("images", "jpeg-garbage.jpg", b"\xff\xd8" + bytes(RNG.randrange(256) for _ in range(2000)))
put("images", "pgm-huge.pgm", b"P5\n# c\n99999 99999\n255\n" + b"\0" * 100)
put("images", "bmp-huge.bmp", b"BM" + b"\0" * 16 + struct.pack("<ii", 60000, -60000) + b"\0" * 100)
put("images", "tiff-huge.tif", b"II*\0" + struct.pack("<I", 8) + struct.pack("<H", 2)
    + struct.pack("<HHII", 256, 4, 1, 100000) + struct.pack("<HHII", 257, 4, 1, 100000) + b"\0" * 8)
mutants("images", "board", ".png", png(120, 100, board), 10)

# --- Metashape calibration XML (interop/metashape.cc over Expat) ---------------------------------------
ms = (b'<?xml version="1.0" encoding="UTF-8"?>\n<calibration>\n  <projection>frame</projection>\n'
      b"  <width>4288</width>\n  <height>2848</height>\n  <f>4690.5</f>\n  <cx>-3.2</cx>\n  <cy>5.1</cy>\n"
      b"  <b1>0.4</b1>\n  <k1>-0.1</k1>\n  <k2>0.05</k2>\n  <k3>0.01</k3>\n  <p1>1e-4</p1>\n  <p2>-2e-4</p2>\n"
      b"  <date>2024-05-26T08:27:27Z</date>\n  <covariance>\n    <params>f cx cy k1</params>\n"
      b"    <coeffs>4 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1e-6</coeffs>\n  </covariance>\n</calibration>\n")
put("metashape", "valid-frame.xml", ms)
put("metashape", "valid-fisheye.xml", ms.replace(b"frame", b"fisheye").replace(b"<b1>0.4</b1>", b""))
put("metashape", "valid-photoscan.xml",
    b"<calibration><projection>frame</projection><width>4288</width><height>2848</height><fx>4691</fx>"
    b"<fy>4690</fy><cx>2141</cx><cy>1429</cy><skew>2.2</skew><k1>-0.1</k1><k4>0.001</k4><p1>1e-4</p1></calibration>")
put("metashape", "valid-refit-k4-b2.xml", ms.replace(b"<b1>0.4</b1>", b"<b2>1.5</b2><k4>0.002</k4><p3>0.1</p3>"))
put("metashape", "billion-laughs.xml",
    b'<?xml version="1.0"?>\n<!DOCTYPE lolz [<!ENTITY lol "lol">'
    + b"".join(b'<!ENTITY lol%d "%s">' % (i, (b"&lol%d;" % (i - 1) if i > 1 else b"&lol;") * 10) for i in range(1, 10))
    + b"]>\n<calibration><f>&lol9;</f></calibration>\n")
put("metashape", "external-entity.xml",
    b'<?xml version="1.0"?>\n<!DOCTYPE c [<!ENTITY x SYSTEM "file:///etc/passwd">]>\n<calibration><f>&x;</f></calibration>\n')
put("metashape", "deep-nesting.xml", b"<a>" * 20000 + b"</a>" * 20000)
put("metashape", "many-elements.xml", b"<calibration>" + b"<k1>0</k1>" * 20000 + b"</calibration>")
put("metashape", "covariance-huge.xml", ms.replace(b"4 0 0 0 0 1", b"1 " * 100000 + b"4 0 0 0 0 1"))
put("metashape", "covariance-negative.xml", ms.replace(b"<coeffs>4 ", b"<coeffs>-4 "))
put("metashape", "width-overflow.xml", ms.replace(b"4288", b"99999999999999999999"))
put("metashape", "f-zero.xml", ms.replace(b"4690.5", b"0"))
put("metashape", "f-nan.xml", ms.replace(b"4690.5", b"nan"))
put("metashape", "not-xml.xml", b"\xff\xfe<calibration")
put("metashape", "unclosed.xml", ms[:-15])
mutants("metashape", "frame", ".xml", ms, 25)

# --- calibmar calibration.yaml (interop/refractive.cc), read by the yaml corpus's command -----------
cm = (b"model: OPENCV\n# fx, fy, cx, cy, k1, k2, p1, p2\n"
      b"parameters: [1500.5, 1501.25, 960.5, 540.5, -0.1, 0.05, 0.0001, -0.0002]\n"
      b"# params_est_std_dev: 0.8, 0.7, 0.5, 0.4, 0.001, 0.002, 1e-05, 2e-05\n"
      b"non_svp_model: DOMEPORT\n# Cx, Cy, Cz, int_radius, int_thick, na, ng, nw\n"
      b"non_svp_parameters: [0.002, -0.001, 0.003, 0.1, 0.008, 1, 1.5, 1.334]\n"
      b"# non_svp_est_std_dev: 0.0001, 0.0001, 0.0002\nwidth: 1920\nheight: 1080\n# overall_rms: 0.21\n"
      b"# target: chessboard, 10, 7, 0.04\n")
put("yaml", "calibmar-valid.yaml", cm)
put("yaml", "calibmar-long-list.yaml", cm.replace(b"[1500.5", b"[" + b"1.5, " * 20000 + b"1500.5"))
put("yaml", "calibmar-long-line.yaml", cm.replace(b"# target", b"#" + b" " * 100000 + b"target"))
put("yaml", "calibmar-width-overflow.yaml", cm.replace(b"1920", b"99999999999999999999"))
mutants("yaml", "calibmar", ".yaml", cm, 15)

# --- OpenCV FileStorage XML and cv::fisheye YAML (interop/opencv_storage.cc) ----------------------------
cvx = (b'<?xml version="1.0"?>\n<opencv_storage>\n<image_width>640</image_width>\n<image_height>480</image_height>\n'
       b'<camera_matrix type_id="opencv-matrix">\n  <rows>3</rows>\n  <cols>3</cols>\n  <dt>d</dt>\n  <data>\n'
       b"    5.3591573396163199e+02 0. 3.4228315473308373e+02 0. 5.3591573396163199e+02\n"
       b"    2.3557082909788173e+02 0. 0. 1.</data></camera_matrix>\n"
       b'<distortion_coefficients type_id="opencv-matrix">\n  <rows>5</rows>\n  <cols>1</cols>\n  <dt>d</dt>\n'
       b"  <data>\n    -0.26 -0.038 1.7e-03 -2.8e-04 0.05</data></distortion_coefficients>\n</opencv_storage>\n")
put("opencv_xml", "valid-pinhole.xml", cvx)
put("opencv_xml", "valid-camel.xml", cvx.replace(b"camera_matrix", b"cameraMatrix")
    .replace(b"distortion_coefficients", b"distCoeffs")
    .replace(b"<image_width>640</image_width>\n<image_height>480</image_height>", b"<imageSize>640 480</imageSize>"))
put("opencv_xml", "valid-fisheye.xml", cvx.replace(b"<rows>5</rows>", b"<rows>4</rows>")
    .replace(b" 0.05</data>", b"</data>").replace(b"<opencv_storage>\n", b"<opencv_storage>\n<fisheye_model>1</fisheye_model>\n"))
put("opencv_xml", "billion-laughs.xml",
    b'<?xml version="1.0"?>\n<!DOCTYPE lolz [<!ENTITY lol "lol">'
    + b"".join(b'<!ENTITY lol%d "%s">' % (i, (b"&lol%d;" % (i - 1) if i > 1 else b"&lol;") * 10) for i in range(1, 10))
    + b"]>\n<opencv_storage><image_width>&lol9;</image_width></opencv_storage>\n")
put("opencv_xml", "external-entity.xml",
    b'<?xml version="1.0"?>\n<!DOCTYPE c [<!ENTITY x SYSTEM "file:///etc/passwd">]>\n<opencv_storage>&x;</opencv_storage>\n')
put("opencv_xml", "deep-nesting.xml", b"<opencv_storage>" + b"<a>" * 20000 + b"</a>" * 20000 + b"</opencv_storage>")
put("opencv_xml", "long-data.xml", cvx.replace(b"    -0.26", b"    " + b"0 " * 100000 + b"-0.26"))
put("opencv_xml", "rows-cols-mismatch.xml", cvx.replace(b"<rows>5</rows>", b"<rows>7</rows>"))
put("opencv_xml", "rows-huge.xml", cvx.replace(b"<rows>5</rows>", b"<rows>99999999999999999999</rows>"))
put("opencv_xml", "width-overflow.xml", cvx.replace(b"640", b"99999999999999999999"))
put("opencv_xml", "fx-nan.xml", cvx.replace(b"5.3591573396163199e+02 0.", b"nan 0.", 1))
put("opencv_xml", "k3-strong.xml", cvx.replace(b" 0.05</data>", b" 2.3839153080878486e-01</data>"))
put("opencv_xml", "unclosed.xml", cvx[:-20])
mutants("opencv_xml", "pinhole", ".xml", cvx, 15)
kd = (b"%YAML:1.0\n---\nimage_width: 1920\nimage_height: 1080\nK: !!opencv-matrix\n   rows: 3\n   cols: 3\n"
      b"   dt: d\n   data: [ 700., 0., 960., 0., 701., 540., 0., 0., 1. ]\nD: !!opencv-matrix\n   rows: 4\n"
      b"   cols: 1\n   dt: d\n   data: [ 0.02, -0.005, 0.001, -0.0002 ]\n")
put("yaml", "fisheye-kd.yml", kd)
put("yaml", "fisheye-contradiction.yml", kd + b"fisheye_model: 1\ndistortion_model: plumb_bob\n")
mutants("yaml", "fisheye", ".yml", kd, 10)

# --- COLMAP cameras.txt, several cameras and refractive COLMAP's housing (interop/colmap.cc) -------------
ct = (b"# Camera list with one line of data per camera:\n#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n"
      b"1 OPENCV 1920 1080 1500.5 1501.25 960.5 540.5 -0.1 0.05 0.0001 -0.0002 DOMEPORT 0.002 -0.001 0.003 0.1 "
      b"0.008 1 1.5 1.334\n")
put("colmap", "valid-domeport.txt", ct)
put("colmap", "valid-refrac-token.txt", ct.replace(b" DOMEPORT", b" REFRAC DOMEPORT"))
put("colmap", "valid-flatport.txt", ct.replace(b"DOMEPORT 0.002 -0.001 0.003", b"FLATPORT 0 0 1"))
put("colmap", "two-cameras.txt", ct + b"2 SIMPLE_PINHOLE 800 600 700 400.5 300.5\n")
put("colmap", "housing-short.txt", ct.replace(b" 1.334\n", b"\n"))
put("colmap", "housing-unknown.txt", ct.replace(b"DOMEPORT", b"SPHEREPORT"))
put("colmap", "flat-normal-zero.txt", ct.replace(b"DOMEPORT 0.002 -0.001 0.003", b"FLATPORT 0 0 0"))
put("colmap", "long-line.txt", ct.replace(b" 1.334\n", b" 1.334" + b" 1" * 100000 + b"\n"))
put("colmap", "width-overflow.txt", ct.replace(b"1920", b"99999999999999999999"))
mutants("colmap", "domeport", ".txt", ct, 15)

# --- target fields (coded/sheet.cc ParseField: "id x_mm y_mm z_mm" lines) ---------------------------------
fd = (b"# porthole target field: coded:12:2:aicon, raised targets\n# id x_mm y_mm z_mm\n"
      b"1 20 20 0\n2 40 20 0\n3 60 20 -15.5\n4 20, 40, 0\n5 40 40 0\n6 60 40 -30\n7 20 60 0\n8 40 60 0\n"
      b"9 60 60 0\n200 30 30 0\n")
put("field", "valid-3d.txt", fd)
put("field", "valid-crlf.txt", fd.replace(b"\n", b"\r\n"))
put("field", "duplicate-id.txt", fd + b"3 1 2 3\n")
put("field", "id-zero.txt", fd + b"0 1 2 3\n")
put("field", "id-huge.txt", fd + b"4294967297 1 2 3\n")
put("field", "id-fraction.txt", fd + b"12.5 1 2 3\n")
put("field", "nan.txt", fd + b"12 nan 2 3\n")
put("field", "inf.txt", fd + b"12 1 inf 3\n")
put("field", "hex-float.txt", fd + b"12 0x1p3 2 3\n")
put("field", "three-numbers.txt", fd + b"12 1 2\n")
put("field", "five-numbers.txt", fd + b"12 1 2 3 4\n")
put("field", "empty.txt", b"")
put("field", "only-comments.txt", b"# nothing\n\n   \n")
put("field", "binary.txt", bytes(range(256)) * 8)
put("field", "nul-in-line.txt", fd.replace(b"5 40 40 0", b"5 40\x0040 0"))
put("field", "long-line.txt", b"1 " + b"1" * 200000 + b" 2 3\n")
put("field", "latin1-comment.txt", b"# Mus\xe9e\n" + fd)
put("field", "all-on-a-line.txt", b"".join(b"%d %d 0 0\n" % (i, 10 * i) for i in range(1, 40)))
put("field", "many-ids.txt", b"".join(b"%d %d %d 0\n" % (i, i % 100, i // 100) for i in range(1, 20001)))
# Targets facing other ways (the optional normal: "id x y z nx ny nz"): a cage's walls.
fn = (b"# a cage: id x_mm y_mm z_mm [nx ny nz]\n1 0 0 0\n2 0 45 -30 1 0 0\n3 300 45 -30 -1 0 0\n"
      b"4 45 0 -30 0 1 0\n5 45 300 -30 0 -1 0\n6 150 150 0 0 0 -1\n7 10 10 -5 0.2,0.1,-1\n8 100 100 0\n")
put("field", "normals.txt", fn)
put("field", "normal-zero.txt", fd + b"12 1 2 3 0 0 0\n")
put("field", "normal-tiny.txt", fd + b"12 1 2 3 1e-300 0 0\n")
put("field", "normal-nan.txt", fd + b"12 1 2 3 nan 0 1\n")
put("field", "six-numbers.txt", fd + b"12 1 2 3 0 1\n")
put("field", "eight-numbers.txt", fd + b"12 1 2 3 0 0 1 5\n")
mutants("field", "field", ".txt", fd, 15)
mutants("field", "normals", ".txt", fn, 8)
