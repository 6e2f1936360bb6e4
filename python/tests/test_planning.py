"""Proves porthole.plan() and porthole.flat() give the paper's Section 4 depth of field, the Fig. 12
minimum working distance and the flat port's 97.2 deg limit, with keyword-only options and
ValueError naming the keyword."""
import math

import pytest

import porthole


def test_plan_section4_from_python():
    p = porthole.plan(port="nimar-ni320-nominal", water_index=1.341, subject_distance_mm=1000, f_number=8,
                      coc_mm=0.015)
    assert 680 <= p.min_wd_mm <= 730
    assert abs(p.dof.water.virtual_focus_mm - 238) <= 1  # Menna et al. 2016, Section 4
    assert abs(p.dof.water.near_mm - 792) <= 0.02 * 792
    assert abs(p.dof.air.near_mm - 831) <= 3


def test_flat_max_fov():
    f = porthole.flat(water_index=1.333)
    assert abs(f.max_fov_deg - 2 * math.degrees(math.asin(1 / 1.333))) < 1e-9
    assert abs(f.max_fov_deg - 97.2) <= 0.1


def test_plan_errors():
    with pytest.raises(ValueError, match="^f_number:"):
        porthole.plan(f_number=64)
    with pytest.raises(TypeError):
        porthole.plan("nikon-d300")  # keyword-only


def test_same_names_and_keywords_as_the_cli():
    # A fixed-lens camera brings its own lens; a lensfun fisheye is planned with its projection.
    p = porthole.plan(camera="gopro-hero4-black", port="flat-acrylic-10mm", f_number=2.8)
    assert p.lens.name == "gopro-hero4-black-wide"
    f = porthole.plan(lens="Nikon AF DX Fisheye-Nikkor 10.5mm f/2.8G ED")
    r = 0.5 * math.hypot(4288 * 0.0055, 2848 * 0.0055)
    assert f.fov.air.diagonal_deg == pytest.approx(4 * math.degrees(math.asin(r / 21)))
    # Errors name Python's keywords: a lensfun zoom needs focal_mm.
    with pytest.raises(ValueError, match="^focal_mm:"):
        porthole.plan(lens="Nikon AF-S DX Nikkor 18-300mm f/3.5-6.3G ED VR")
    s = porthole.simulate(camera="olympus-tg6", port="flat-acrylic-10mm", grid_cols=5, grid_rows=5)
    assert s.model == "brown"


def test_pixel_pitch_of_a_preset_body_as_the_cli():
    # A preset body given another pitch keeps its sensor (23.58 x 15.66 mm) with other pixels, in
    # Python as in the CLI (`plan --pixel-pitch-mm 0.011`): 2144 x 1424 px, and the default circle
    # of confusion (two pitches) follows.
    p = porthole.plan(pixel_pitch_mm=0.011)
    assert (p.camera.width_px, p.camera.height_px) == (round(4288 * 0.0055 / 0.011), round(2848 * 0.0055 / 0.011))
    assert p.coc_mm == pytest.approx(0.022)
    with pytest.raises(ValueError, match="^pixel_pitch_mm:"):
        porthole.plan(pixel_pitch_mm=-1)


def test_names_exact_and_lens_data_keywords():
    # Issue 23: a name lensfun does not have is refused with candidates, never another camera; the
    # minimum focus lensfun lacks is assumed (and said) or given as min_focus_mm= (as --min-focus-mm).
    with pytest.raises(ValueError, match="^camera: .*did you mean"):
        porthole.plan(camera="Sony A7R V", pixel_pitch_mm=0.004)
    kw = dict(camera="sony-a7iv", lens="Sony FE 16-35mm f/4 ZA OSS", focal_mm=16, port="generic-dome-8in")
    assumed = porthole.plan(**kw)
    assert assumed.lens.min_focus_assumed is True and assumed.lens.found_in == "lensfun"
    given = porthole.plan(**kw, min_focus_mm=280, pupil_mm=68.1)
    assert given.lens.min_focus_assumed is False and given.lens.pupil_estimated is False
    # Eq. 2 at FD 280 with the pupil 68.1 mm ahead of the sensor (Sony E flange 18 mm), moved f²/(FD − 2f).
    assert given.closest_d_s2ep_mm == pytest.approx(280 - 68.1 - 16 * 16 / (280 - 32), abs=1e-9)
    with pytest.raises(ValueError, match="^min_focus_mm:"):
        porthole.plan(**kw, min_focus_mm=10)
