"""Proves the Python module exposes the libraries faithfully: the paper's Table 5, Snell's law on
batched NumPy rays, keyword-only options (typos raise), and ValueError naming the field."""
import csv
import math
import os

import numpy as np
import pytest

import porthole

DATA = os.environ.get("PORTHOLE_TEST_DATA_DIR", os.path.join(os.path.dirname(__file__), "..", "..", "tests", "data"))


def table5():
    with open(os.path.join(DATA, "menna2016_table5.csv")) as f:
        rows = list(csv.DictReader(line for line in f if not line.startswith("#")))
    return [(float(r["wd_mm"]), float(r["d_s2ep_mm"]), float(r["vwd_mm"])) for r in rows]


def test_table5_from_python():
    sys = porthole.place(porthole.load_port("nimar-ni320-nominal"), water_index=1.341)
    for wd, d, v in table5():
        vi = sys.virtual_image(wd)
        assert abs(vi.d_s2ep_mm - d) <= 0.2 and abs(vi.vwd_mm - v) <= 0.2


def test_index_and_options_are_keyword_only():
    assert porthole.index("seawater") == pytest.approx(1.3409, abs=2e-4)  # Quan-Fry 1995
    assert porthole.index("n-bk7", lambda_nm=587.56) == pytest.approx(1.5168, abs=2e-5)  # Schott n_d
    with pytest.raises(TypeError):
        porthole.index("seawater", lamda_nm=500)  # a typo is an error, not ignored
    with pytest.raises(ValueError, match="lambda_nm"):
        porthole.index("seawater", lambda_nm=1500)


def test_batched_rays_obey_snell_through_flat_port():
    sys = porthole.place(porthole.load_port("flat-acrylic-10mm"), water_index=1.333, glass_index=1.49)
    a = np.radians(np.linspace(-60, 60, 101))
    d = np.stack([np.sin(a), np.zeros_like(a), np.cos(a)], axis=1)
    o = np.tile(sys.ep_in_housing_mm, (len(a), 1))
    out = sys.trace_out(o, d)
    assert (out.status == porthole.RayStatus.OK).all() and out.ok().all()
    np.testing.assert_allclose(np.sin(a), 1.333 * out.directions[:, 0], atol=1e-12)


def test_bad_geometry_raises_value_error():
    with pytest.raises(ValueError, match="entrance_pupil_mm"):
        porthole.place(porthole.load_port("nimar-ni320"), ep_mm=np.array([0.0, 0.0, 300.0]))
    with pytest.raises(ValueError, match="unknown preset"):
        porthole.load_port("no-such-port")
    assert porthole.place(porthole.load_port("nimar-ni320")).virtual_image_real(math.inf).d_s2ep_mm > 280
