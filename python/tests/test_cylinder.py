"""A cylindrical port from Python (issue 25): the same port list as the CLI. The preset loads as a
PortType.CYLINDER, traces (a ray square to the tube from its axis goes straight through), has two
focal lines, and plans and simulates; the optics are checked against closed forms in the C++
tests (optics_test, refraction_test, virtual_image_test)."""
import numpy as np

import porthole

PRESET = "generic-cylinder-acrylic-4in"


def test_the_cylinder_is_a_port_like_the_others():
    assert porthole.load_port(PRESET).type is porthole.PortType.CYLINDER
    tube = porthole.place(PRESET)
    assert tube.type is porthole.PortType.CYLINDER and not tube.is_central
    # The pupil sits on the axis: the ray along +Z meets both walls square and goes straight.
    out = tube.trace_out(np.array([tube.ep_in_housing_mm]), np.array([[0.0, 0.0, 1.0]]))
    assert porthole.RayStatus(out.status[0]) is porthole.RayStatus.OK
    np.testing.assert_allclose(out.directions[0], [0, 0, 1], atol=1e-15)
    assert abs(out.origins_mm[0][2] - tube.ep_in_housing_mm[2] - 57.15) < 1e-9
    vi = tube.virtual_image(1000.0)
    assert vi.focal_line_near_d_s2ep_mm < vi.d_s2ep_mm < vi.focal_line_far_d_s2ep_mm


def test_plan_and_simulate_take_the_cylinder():
    p = porthole.plan(port=PRESET)
    assert p.port.type == "cylinder" and 0 < p.d_s2ep_infinity_mm < 300
    # A fisheye focuses close enough: the water calibration is astigmatic, as `porthole simulate`'s.
    s = porthole.simulate(port=PRESET, lens="nikkor-10.5mm-f2.8g-fisheye", grid_cols=9, grid_rows=7)
    assert s.water.fy_px / s.air.fy_px > 1.25 > 1.05 > s.water.fx_px / s.air.fx_px
