"""segment_cloud as a user runs it: a range image of the ramp scene written by
scene_cloud (its faces as labels), judged with the default tolerances and with
--noise auto, every line grouped and every second (the default line spacing on
a grid 0.25 degrees apart), and the options' bad values refused."""
import math
import os
import re
import subprocess

HERE = os.path.dirname(os.path.realpath(__file__))
ROOT = os.path.dirname(HERE)
BIN = os.environ.get("TLP_BIN", os.path.join(ROOT, "build_ws", "build", "tilt_laser_perception", "devel", "lib",
                                             "tilt_laser_perception"))


def run(*args):
    return subprocess.run([os.path.join(BIN, args[0])] + list(args[1:]), capture_output=True, text=True, timeout=120)


def judged(cloud, noise, *more):
    r = run("segment_cloud", cloud, "--truth-field", "label", "--truth-none", "0", "--noise", noise, *more)
    assert r.returncode == 0, r.stderr
    m = re.search(r": (\d+) planes; at 80 % overlap: correct=(\d+) over=(\d+) under=(\d+) missed=(\d+) noise=(\d+)",
                  r.stdout)
    assert m, r.stdout
    return [int(g) for g in m.groups()], r.stdout


def test_noise_auto_on_a_range_image(tmp_path):
    cloud = str(tmp_path / "ramp.pcd")
    r = run("scene_cloud", cloud, "--scene", "ramp", "--size", "200", "--sigma", "0.001", "--seed", "1")
    assert r.returncode == 0, r.stderr
    # Every line grouped (the lines 0.25 degrees apart).
    (true, correct, *_), out = judged(cloud, "off", "--line-spacing-deg", "0")
    assert "range noise" not in out and "grouped" not in out
    assert (true, correct) == (9, 7)
    (true, correct, over, under, missed, noise), out = judged(cloud, "auto", "--line-spacing-deg", "0")
    m = re.search(r"range noise ([\d.]+) mm \(estimated\), beams ([\d.]+) deg apart: tolerances x ([\d.]+)", out)
    assert m, out
    sigma_mm, step_deg, k = (float(g) for g in m.groups())
    assert abs(sigma_mm - 1.0) < 0.2
    assert abs(step_deg - 0.49) < 0.02
    assert abs(k - sigma_mm / 5.0) < 0.011
    assert (true, correct, noise) == (9, 8, 0)
    # A noise given: 1 cm is no less than the defaults' 5 mm, the defaults hold.
    (_, correct_given, *_), out = judged(cloud, "0.01", "--line-spacing-deg", "0")
    assert "(given)" in out and "tolerances x 1.00" in out
    assert correct_given == 7


def test_lines_closer_than_the_spacing_grouped_every_kth(tmp_path):
    # The default spacing, 0.5 degrees, groups every second of these lines and
    # joins the points of the others to the planes: no face lost, and here the
    # landing and the ramp (5.7 degrees apart) part with the defaults too.
    cloud = str(tmp_path / "ramp.pcd")
    r = run("scene_cloud", cloud, "--scene", "ramp", "--size", "200", "--sigma", "0.001", "--seed", "1")
    assert r.returncode == 0, r.stderr
    (true, correct, over, under, missed, noise), out = judged(cloud, "off")
    assert "closer than 0.50 deg: every 2. grouped" in out
    assert (true, correct, noise) == (9, 8, 0)
    points = int(re.search(r"(\d+) points in planes", out).group(1))
    (_, correct_all, *_), out_all = judged(cloud, "off", "--line-spacing-deg", "0")
    points_all = int(re.search(r"(\d+) points in planes", out_all).group(1))
    assert correct_all == 7
    # The points between grouped lines join planes: as many points in planes within 1 %.
    assert abs(points - points_all) < 0.01 * points_all
    r = run("segment_cloud", cloud, "--line-spacing-deg", "-1")
    assert r.returncode == 2 and "usage" in r.stderr


def test_bad_noise_values_are_refused(tmp_path):
    for bad in ("bogus", "-0.001", "0", "1mm"):
        r = run("segment_cloud", str(tmp_path / "none.pcd"), "--noise", bad)
        assert r.returncode == 2, (bad, r.stdout, r.stderr)
        assert "usage" in r.stderr


def test_two_threads_give_the_same_planes_and_labels(tmp_path):
    # --threads 2 (the default on two cores or more) splits the lines on a
    # second thread while the first groups them: the same planes, to the
    # printed digit, and the same label for every point.
    cloud = str(tmp_path / "ramp.pcd")
    r = run("scene_cloud", cloud, "--scene", "ramp", "--size", "200", "--sigma", "0.01", "--seed", "2")
    assert r.returncode == 0, r.stderr
    outs = {}
    for t in ("1", "2"):
        labels = str(tmp_path / ("labels%s.pcd" % t))
        r = run("segment_cloud", cloud, "--threads", t, "--out", labels)
        assert r.returncode == 0, r.stderr
        assert "(%s thread%s)" % (t, "s" if t == "2" else "") in r.stdout
        rows = [l for l in r.stdout.splitlines() if re.match(r"^\d+,", l)]
        assert len(rows) >= 5, r.stdout
        with open(labels, "rb") as f:
            outs[t] = (rows, f.read())
    assert outs["1"][0] == outs["2"][0]
    assert outs["1"][1] == outs["2"][1]
    for bad in ("0", "-2", "3"):
        r = run("segment_cloud", cloud, "--threads", bad)
        assert r.returncode == 2 and "usage" in r.stderr


SHARED = os.path.join(ROOT, "..", "shared", "data")


def test_the_line_pose_error_is_estimated_or_given(tmp_path):
    # A range image's rows have no pose error of their own: next to nothing
    # estimated; a value given is taken as it is; a bad one refused.
    cloud = str(tmp_path / "ramp.pcd")
    assert run("scene_cloud", cloud, "--scene", "ramp", "--size", "200", "--sigma", "0.001", "--seed", "1").returncode == 0
    _, out = judged(cloud, "off")
    m = re.search(r"line pose error ([\d.]+) deg \(estimated\)", out)
    assert m and float(m.group(1)) < 0.05, out
    _, out = judged(cloud, "off", "--line-sigma-deg", "0.5")
    assert "line pose error 0.500 deg (given)" in out, out
    r = run("segment_cloud", cloud, "--line-sigma-deg", "-1")
    assert r.returncode == 2


def surface_shares(out):
    """Per --surface: (largest plane's share, share in planes, planes for 80 %, the largest plane's id)."""
    return {m.group(1): (float(m.group(2)), float(m.group(4)), m.group(5), int(m.group(3))) for m in re.finditer(
        r"surface (\w+): \d+ points .*?largest plane ([\d.]+) % \(plane (-?\d+)\), in planes ([\d.]+) %, "
        r"planes for 80 %: (\w+)", out)}


def test_synpeb_by_its_own_noise_with_the_defaults():
    # SynPEB's test_100 (../shared/data/synpeb): about 1 mm of range noise. By
    # default segment_cloud measures it and judges the cloud by it (10 of 13
    # planes correct, noise 0); with this head's tolerances (--noise off) faces
    # that meet at 24 degrees share planes (4 correct, 3 planes of two faces).
    cloud = os.path.join(SHARED, "synpeb", "test_100.pcd")
    if not os.path.exists(cloud):
        import pytest
        pytest.skip(f"{cloud} is absent (shared data)")
    found = {}
    for name, more in (("defaults", []), ("off", ["--noise", "off"])):
        r = run("segment_cloud", cloud, "--truth-field", "intensity", *more)
        assert r.returncode == 0, r.stderr
        m = re.search(r": (\d+) planes; at 80 % overlap: correct=(\d+) .* noise=(\d+)", r.stdout)
        assert m, r.stdout
        found[name] = tuple(int(g) for g in m.groups())
    assert "range noise 1.1 mm (estimated)" in run("segment_cloud", cloud).stdout
    # 10 of 13 since the split of organized clouds merges its pieces again as
    # the 2D split does (9 before).
    assert found["defaults"][0] == 13 and found["defaults"][1] >= 10 and found["defaults"][2] <= 1, found
    assert found["off"][1] <= 7, found


def test_the_nodding_sick_scans_ceiling_with_the_line_term():
    # 3DTK's scan000.3d (../shared/data/real/3dtk): each line's own tilt error
    # puts the ceiling's lines centimetres off one plane. Without the line term
    # the ceiling comes out in stripes (largest plane 32 %); with the term
    # estimated from the scan (0.33 deg), which each plane's tilt and the
    # merge allow for, its largest plane holds 55 % and the same within 1 %
    # with the lines in the other order (before the tilt held it, 66 % one way
    # and 51 % the other), and 80 % of it lies in planes. The 80 % in
    # at most two planes is not reached (doc/notes/noise_model.md says why).
    scan = os.path.join(SHARED, "real", "3dtk", "scan000.3d")
    if not os.path.exists(scan):
        import pytest
        pytest.skip(f"{scan} is absent (shared data)")
    boxes = ["--surface", "ceiling:-40,40,-40,40,1.85,2.15", "--surface", "floor:-40,40,-40,40,-0.6,-0.3"]
    outs = {}
    for name, more in (("estimated", []), ("off", ["--line-sigma-deg", "0"]), ("reversed", ["--reverse"])):
        r = run("segment_cloud", scan, *boxes, *more)
        assert r.returncode == 0, r.stderr
        outs[name] = r.stdout
    sigma = float(re.search(r"line pose error ([\d.]+) deg \(estimated\)", outs["estimated"]).group(1))
    assert 0.25 < sigma < 0.5, outs["estimated"]
    est, off, rev = (surface_shares(outs[k]) for k in ("estimated", "off", "reversed"))
    assert off["ceiling"][0] < 40.0, outs["off"]
    assert est["ceiling"][0] > 50.0 and rev["ceiling"][0] > 50.0, outs["estimated"] + outs["reversed"]
    assert abs(est["ceiling"][0] - rev["ceiling"][0]) < 1.0, outs["estimated"] + outs["reversed"]
    assert est["ceiling"][1] >= 80.0, outs["estimated"]
    # The floor 65 % in its largest plane either way (62 % one way before the
    # merge judged again the planes that the late joins brought together).
    assert est["floor"][0] > 65.0 and rev["floor"][0] > 65.0, outs["estimated"] + outs["reversed"]
    # 80 % of the ceiling in 3 planes and of the floor in 4, either way, since
    # the split of organized clouds merges its pieces again as the 2D split
    # does (7 and 5 planes before, 80 % never reached on the ceiling reversed;
    # the issue asks 2).
    for shares, out in ((est, outs["estimated"]), (rev, outs["reversed"])):
        assert shares["ceiling"][2] != "never" and int(shares["ceiling"][2]) <= 3, out
        assert shares["floor"][2] != "never" and int(shares["floor"][2]) <= 4, out


def test_a_spinning_lasers_flat_cloud_in_scan_order(tmp_path):
    # ../shared/data/real/drc/tilted-steps.pcd: a MultiSense SL's spinning
    # UTM-30LX over cinder blocks, one flat list of points in the order
    # measured. Given the file alone, the spin axis and the laser's place are
    # estimated (printed), its lines rebuilt (about 500 by the README's count
    # of 0.47 degrees of spin) and segmented: each block top and the ground
    # largely in one plane. The README's origin and axis give the same.
    cloud = os.path.join(SHARED, "real", "drc", "tilted-steps.pcd")
    if not os.path.exists(cloud):
        import pytest
        pytest.skip(f"{cloud} is absent (shared data)")
    tops = {"A": "0.57,0.91,-0.12,0.13,0.12,0.22", "B": "0.97,1.30,-0.12,0.13,0.28,0.36",
            "C1": "0.57,0.91,-0.58,-0.28,0.13,0.21", "C2": "0.99,1.32,-0.58,-0.28,0.10,0.16",
            "D": "1.39,1.72,-0.58,-0.28,0.11,0.22", "ground": "-10,10,-10,10,-0.07,0.03"}
    boxes = [a for name, box in tops.items() for a in ("--surface", f"{name}:{box}")]
    results = {}
    for given in ([], ["--origin", "0.248091,0.012443,1.806473", "--axis", "0.837001,0.019831,-0.546842"]):
        r = run("segment_cloud", cloud, *given, *boxes)
        assert r.returncode == 0, r.stderr
        if not given:
            est = re.search(r"spin axis estimated .*?: origin (\S+) axis (\S+);", r.stdout)
            assert est, r.stdout
            origin = [float(v) for v in est.group(1).split(",")]
            axis = [float(v) for v in est.group(2).split(",")]
            readme = (0.837001, 0.019831, -0.546842)
            cos = sum(a * b for a, b in zip(axis, readme)) / math.sqrt(sum(b * b for b in readme))
            assert math.degrees(math.acos(min(1.0, cos))) < 0.1, r.stdout
            # The README's origin lies 1 cm off the estimated axis and 8 cm
            # along it: from there the beams lie less evenly apart (2.0 % of
            # their step against 0.9 %) and 12 lines of 2 points appear.
            assert math.dist(origin, (0.248091, 0.012443, 1.806473)) < 0.12, r.stdout
        lines = int(re.search(r"(\d+) scan lines of up to \d+ beams ([\d.]+) deg apart", r.stdout).group(1))
        step = float(re.search(r"scan lines of up to \d+ beams ([\d.]+) deg apart", r.stdout).group(1))
        assert 350 <= lines <= 550, r.stdout
        assert abs(step - 0.25) < 0.02, r.stdout
        shares = surface_shares(r.stdout)
        for name in ("A", "B", "C1", "C2", "D"):
            assert shares[name][0] >= 90.0, (name, r.stdout)
        assert shares["ground"][0] >= 80.0, r.stdout
        # No two tops share a plane: C1 (sloping 13 degrees) and C2 (level),
        # side by side, are each fixed by their lines to a degree or two, and
        # their normals agree within neither's uncertainty (before, the
        # merge's 15 degrees alone judged them, and they shared one).
        assert len({shares[n][3] for n in ("A", "B", "C1", "C2", "D")}) == 5, r.stdout
        results[bool(given)] = shares
    for name in tops:
        assert abs(results[True][name][0] - results[False][name][0]) < 5.0, (name, results)
    # A flat cloud that is no spinning laser's (points of one plane, in no
    # order): a clear message.
    flat = tmp_path / "flat.pcd"
    pts = [(0.01 * (i * 37 % 101), 0.01 * (i * 53 % 97), 0.0) for i in range(500)]
    flat.write_text("VERSION .7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 500\nHEIGHT 1\n"
                    "VIEWPOINT 0 0 0 1 0 0 0\nPOINTS 500\nDATA ascii\n" + "".join(f"{x} {y} {z}\n" for x, y, z in pts))
    r = run("segment_cloud", str(flat))
    assert r.returncode == 1 and "spin axis could not be found" in r.stderr and "--axis" in r.stderr, r.stderr
