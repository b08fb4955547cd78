"""The rviz screenshot check (scripts/dev/check_screenshot.py) on real rviz
screenshots of the stairs scene (test/data/rviz, taken with
scripts/dev/rviz_screenshot.sh): it passes the full view and fails each view with
one display switched off."""
import os
import subprocess
import sys

import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
CHECK = os.path.join(HERE, "..", "scripts", "dev", "check_screenshot.py")
DATA = os.path.join(HERE, "data", "rviz")
sys.path.insert(0, os.path.join(HERE, "..", "scripts", "dev"))
import check_screenshot  # noqa: E402


def run(name):
    p = subprocess.run([sys.executable, CHECK, os.path.join(DATA, name)], capture_output=True, text=True)
    return p.returncode, p.stdout


def test_full_view_passes():
    rc, out = run("full.png")
    assert rc == 0, out
    assert out.count(" ok") == 3


@pytest.mark.parametrize("name,missing", [("no_planes.png", "planes"), ("no_height_map.png", "height map"),
                                          ("no_sweep_cloud.png", "points")])
def test_view_without_a_display_fails(name, missing):
    rc, out = run(name)
    assert rc == 1, out
    bad = [line.split(":")[0].strip() for line in out.splitlines() if line.endswith("MISSING")]
    assert bad == [missing], out


def test_empty_view_fails():
    import numpy as np
    img = np.zeros((800, 1280, 3), dtype=np.uint8)
    img[:] = (40, 40, 48)  # rviz/tilt_laser.rviz background
    frac = check_screenshot.classify(img)
    assert frac == {"planes": 0.0, "height map": 0.0, "points": 0.0}


def test_classes_of_the_palettes():
    import numpy as np
    # one pixel per colour: a plane colour, a height map colour at low and high, the sweep cloud's teal
    px = np.array([[[242, 140, 25], [0, 38, 140], [115, 230, 255], [0, 255, 200]]], dtype=np.uint8)
    for i, want in enumerate(("planes", "height map", "height map", "points")):
        frac = check_screenshot.classify(px[:, i:i + 1])
        assert frac[want] == 1.0, (i, frac)


def test_the_rviz_config_loads_with_its_displays():
    # rviz drops a configuration it cannot parse and shows an empty window
    # (a display name with a colon in it did that): the file is YAML whose
    # displays are the ones the check counts, on the grouper's topics.
    import yaml
    with open(os.path.join(HERE, "..", "rviz", "tilt_laser.rviz")) as f:
        config = yaml.safe_load(f)
    displays = config["Visualization Manager"]["Displays"]
    topics = {d.get("Topic") or d.get("Marker Topic") for d in displays}
    assert {"height_map_cloud", "plane_markers", "sweep_cloud", "steppable_grid"} <= topics, topics
    assert all(isinstance(d.get("Name"), str) and isinstance(d.get("Class"), str) for d in displays)
