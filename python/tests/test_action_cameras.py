"""Proves Python plans and reports an action camera behind its flat port with the CLI's defaults
(issue 28): plan() takes the fixed-aperture lens's own f-number (f/8 was refused), and report()
chooses a comparison dome the fixed-focus lens can focus through (the NI320 made it fail), as
`porthole plan` and `porthole report` do."""
import porthole
from test_notebook import cli_json


def test_plan_takes_the_lens_own_aperture():
    ours = porthole.plan(camera="gopro-hero9-black", port="generic-flat-action-housing", wd_mm=1000)
    theirs = cli_json("plan", "--camera", "gopro-hero9-black", "--port", "generic-flat-action-housing", "--wd", "1000")
    assert ours.f_number == theirs["f_number"] == 2.5
    assert porthole.plan(port="nimar-ni320", wd_mm=1000).f_number == 8  # an SLR lens keeps f/8


def test_report_of_an_action_camera(tmp_path):
    s = porthole.report(tmp_path / "r", camera="gopro-hero9-black", port="generic-flat-action-housing")
    page = (tmp_path / "r" / "index.html").read_text()
    assert "generic-dome-230mm-glass" in page
    assert s.index_html
