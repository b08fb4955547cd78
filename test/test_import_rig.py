"""import_tilt_bag.py and group_bag on recordings of another rig: a synthetic
stepping stand over a floor, written in the tilting_lidar_scanner's own message
type (pcg_node/LaserScanAngle, generated from its definition as rosbag does),
and, when ../shared/data is there, the real room_240 recording."""
import math
import os
import re
import subprocess
import sys

import pytest

HERE = os.path.dirname(os.path.realpath(__file__))
ROOT = os.path.dirname(HERE)
IMPORT = os.path.join(ROOT, "scripts", "import_tilt_bag.py")
BIN = os.environ.get("TLP_BIN", os.path.join(ROOT, "build_ws", "build", "tilt_laser_perception", "devel", "lib",
                                             "tilt_laser_perception"))
SHARED = os.path.join(ROOT, "..", "shared", "data", "real", "tilting_lidar_scanner")

DEFINITION = """sensor_msgs/LaserScan laserScan
float64 stepAngle
================================================================================
MSG: sensor_msgs/LaserScan
Header header
float32 angle_min
float32 angle_max
float32 angle_increment
float32 time_increment
float32 scan_time
float32 range_min
float32 range_max
float32[] ranges
float32[] intensities
================================================================================
MSG: std_msgs/Header
uint32 seq
time stamp
string frame_id
"""


def stand_bag(path, height=1.1075, arm=0.08, back=20):
    """A stand stepping 10 -> 60 deg and `back` steps back (0.5 deg a scan, 10 Hz) over a floor, as the rig's node
    records it."""
    import genpy.dynamic
    import rosbag
    import rospy
    cls = genpy.dynamic.generate_dynamic("pcg_node/LaserScanAngle", DEFINITION)["pcg_node/LaserScanAngle"]
    tilts = [10 + 0.5 * k for k in range(101)] + [60 - 0.5 * k for k in range(1, back + 1)]
    inc, n = 0.006135923, 681
    amin = -inc * (n - 1) / 2
    with rosbag.Bag(path, "w") as bag:
        for k, deg in enumerate(tilts):
            th = math.radians(deg)
            oz = height + arm * math.cos(th)
            m = cls()
            s = m.laserScan
            s.header.seq = k
            s.header.stamp = rospy.Time(1436377047.0 + 0.1 * k)
            s.header.frame_id = "laser"
            s.angle_min, s.angle_max, s.angle_increment = amin, -amin, inc
            s.time_increment, s.scan_time, s.range_min, s.range_max = 9.765625e-05, 0.1, 0.02, 5.6
            ranges = []
            for i in range(n):
                a = amin + i * inc
                dz = math.cos(a) * math.sin(th)  # the beam's downward component
                t = oz / dz if dz > 1e-6 else float("inf")
                ranges.append(t if t <= 5.6 else float("inf"))
            s.ranges = ranges
            m.stepAngle = deg
            bag.write("/slice", m, s.header.stamp)


def run(*args):
    r = subprocess.run(list(args), capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stdout + r.stderr
    return r.stdout


def test_a_stand_over_a_floor_gives_the_floor_at_zero(tmp_path):
    src, out = str(tmp_path / "stand.bag"), str(tmp_path / "stand_tlp.bag")
    stand_bag(src)
    text = run(sys.executable, IMPORT, src, out)
    assert "121 scans (681 beams)" in text and "tilt 10.00..60.00 deg" in text, text
    import rosbag
    with rosbag.Bag(out) as bag:
        info = bag.get_type_and_topic_info().topics
        assert info["/scan"].message_count == 121
        assert info["/joint_states"].message_count >= 121 * 9
        qs = [m.position[0] for _, m, _ in bag.read_messages(topics=["/joint_states"])]
    assert abs(max(qs) - math.radians(60)) < 1e-9
    grouped = run(os.path.join(BIN, "group_bag"), out, "--urdf", out[:-4] + ".urdf", "--room")
    m = re.search(r"sweep 0: (\d+) lines", grouped)
    assert m and int(m.group(1)) >= 95, grouped  # the scans from 10 to 60 degrees
    # the largest plane is the floor, horizontal at z = 0 of base_footprint
    p = re.search(r"plane \d+: \d+ points, [\d.]+ m\^2, normal \(([-\d.]+) ([-\d.]+) ([-\d.]+)\), offset ([-\d.]+) m",
                  grouped)
    assert p, grouped
    assert abs(abs(float(p.group(3))) - 1.0) < 1e-3 and abs(float(p.group(4))) < 0.005, grouped
    f = re.search(r"floor at z=([-\d.]+) m: (\d+) points, ([\d.]+) % in plane", grouped)
    assert f and abs(float(f.group(1))) < 0.01 and float(f.group(3)) > 99.0, grouped


def test_a_one_sweep_recording_gives_its_sweep(tmp_path):
    # 10 -> 60 deg and the recording ends: no reversal after the sweep. The
    # recording's end closes it (before: "0 sweeps ... no warnings").
    src, out = str(tmp_path / "one.bag"), str(tmp_path / "one_tlp.bag")
    stand_bag(src, back=0)
    run(sys.executable, IMPORT, src, out)
    grouped = run(os.path.join(BIN, "group_bag"), out, "--urdf", out[:-4] + ".urdf", "--room")
    m = re.search(r"sweep 0: (\d+) lines, (\d+) planes", grouped)
    assert m and int(m.group(1)) >= 95 and int(m.group(2)) >= 1, grouped
    assert "the recording's end closed sweep 0" in grouped, grouped
    assert re.search(r"101 scans, 1 sweeps", grouped), grouped
    f = re.search(r"floor at z=([-\d.]+) m: (\d+) points, ([\d.]+) % in plane", grouped)
    assert f and abs(float(f.group(1))) < 0.01 and float(f.group(3)) > 99.0, grouped
    # No vertical plane in a floor: --room says so rather than calling a slice of the floor a wall.
    assert "no vertical plane above it" in grouped, grouped


def test_a_recording_without_a_sweep_says_why(tmp_path):
    # Without the import's lead-in the tilt never reverses: no sweep began.
    src, out = str(tmp_path / "one.bag"), str(tmp_path / "one_tlp.bag")
    stand_bag(src, back=0)
    run(sys.executable, IMPORT, src, out, "--no-lead-in")
    grouped = run(os.path.join(BIN, "group_bag"), out, "--urdf", out[:-4] + ".urdf")
    assert "0 sweeps" in grouped and "no sweep: the tilt never reversed" in grouped, grouped


def test_the_dump_is_an_organized_cloud_segment_cloud_reads(tmp_path):
    src, out = str(tmp_path / "stand.bag"), str(tmp_path / "stand_tlp.bag")
    stand_bag(src)
    run(sys.executable, IMPORT, src, out)
    prefix = str(tmp_path / "stand")
    grouped = run(os.path.join(BIN, "group_bag"), out, "--urdf", out[:-4] + ".urdf", "--dump", prefix)
    lines = int(re.search(r"sweep 0: (\d+) lines", grouped).group(1))
    cloud = prefix + "_sweep0.pcd"
    header = {}
    with open(cloud) as f:
        for line in f:
            key, _, value = line.strip().partition(" ")
            header[key] = value
            if key == "DATA":
                break
        rows = [line.split() for line in f]
    # A row a scan line, a column a beam; NaN where a beam saw nothing.
    assert header["FIELDS"] == "x y z label" and header["DATA"] == "ascii", header
    assert int(header["WIDTH"]) == 681 and int(header["HEIGHT"]) == lines, header
    assert len(rows) == 681 * lines
    missing = sum(1 for r in rows if r[0] == "nan")
    assert 0 < missing < len(rows)
    # The viewpoint: the laser's mean place, on its 0.08 m arm about the
    # axle 1.1075 m above the floor.
    vx, vy, vz = (float(v) for v in header["VIEWPOINT"].split()[:3])
    assert abs(vy) < 1e-6 and 0.0 < vx < 0.08 and 1.1075 < vz < 1.1075 + 0.08, header
    # segment_cloud reads it as it is: one plane, the floor, holds the points.
    seg = run(os.path.join(BIN, "segment_cloud"), cloud)
    m = re.search(r"681 x %d points, scan lines are rows; (\d+) planes, (\d+) points in planes" % lines, seg)
    assert m, seg
    table = [r.split(",") for r in seg.splitlines() if re.match(r"^\d+,", r)]
    biggest = max(table, key=lambda r: int(r[1]))
    assert abs(abs(float(biggest[6])) - 1.0) < 1e-3 and abs(float(biggest[10])) < 0.005, seg
    assert int(biggest[1]) > 0.95 * (len(rows) - missing), seg


def test_messages_without_the_fields_are_refused(tmp_path):
    src = str(tmp_path / "empty.bag")
    import rosbag
    from std_msgs.msg import String
    with rosbag.Bag(src, "w") as bag:
        bag.write("/slice", String("no scan here"))
    r = subprocess.run([sys.executable, IMPORT, src, str(tmp_path / "out.bag")], capture_output=True, text=True)
    assert r.returncode != 0 and "no message with fields" in r.stderr, r.stderr


@pytest.mark.skipif(not os.path.exists(os.path.join(SHARED, "room_240.bag")),
                    reason="../shared/data/real/tilting_lidar_scanner is absent: the real recording is skipped")
def test_room_240_imports_and_groups(tmp_path):
    out = str(tmp_path / "room_240_tlp.bag")
    text = run(sys.executable, IMPORT, os.path.join(SHARED, "room_240.bag"), out)
    assert "865 scans (681 beams)" in text and "tilt 0.08..60.00 deg" in text, text
    # The room's floor is the lowest surface, 1.0 m below the axle (z = 0.10
    # with the documented 1.1075 m): the stand stands on a table whose edge
    # the laser sees under itself, and sees the floor beyond it 1.1-1.6 m ahead.
    grouped = run(os.path.join(BIN, "group_bag"), out, "--urdf", out[:-4] + ".urdf", "--floor-z", "0.10")
    m = re.search(r"sweep 0: (\d+) lines, (\d+) planes", grouped)
    assert m and int(m.group(1)) >= 790 and int(m.group(2)) >= 3, grouped
    f = re.search(r"floor at z=([-\d.]+) m: (\d+) points, ([\d.]+) % in plane .* largest wall \(normal (\d+) deg, "
                  r"([-\d.]+) m\): (\d+) points, ([\d.]+) % in plane", grouped)
    assert f, grouped
    # The floor and the side wall (y = 1.13 m) each hold 80 % of their points
    # in one plane. The wall's points are all those within 5 cm of it but a
    # level plane's: 84 % of them in one plane. (Until the thirteenth session
    # the judge left out the wall's points that a tilted plane took, about
    # 9,000 of them, and said 91-94 % depending on how many went astray:
    # doc/notes/noise_model.md.)
    assert int(f.group(2)) > 5000 and float(f.group(3)) >= 80.0, grouped
    assert abs(int(f.group(4)) - 90) <= 2 and abs(float(f.group(5)) - 1.13) < 0.03, grouped
    assert int(f.group(6)) > 90000 and float(f.group(7)) >= 80.0, grouped
    # The lines in the other order: the wall as whole within 4 % (89.8 against
    # 86.3 %; 87.3 against 84.5 % until a strip's segments joined the plane
    # beside them late without a member of the lines near theirs overlapping
    # them in beams, which took both up but the forward order's less: its
    # strips at the reversal, near the tilt axis, have no wall member beside
    # them in the lines near theirs). It was 56 % in one plane until the split
    # kept a run's step onto a surface a few centimetres behind out of one
    # segment (its pieces' own lines compared: doc/notes/split.md), 60.5 %
    # before the grazing-rays test.
    rev = run(os.path.join(BIN, "group_bag"), out, "--urdf", out[:-4] + ".urdf", "--floor-z", "0.10", "--reverse")
    r = re.search(r"floor at z=[-\d.]+ m: \d+ points, ([\d.]+) % in plane .* largest wall \(normal (\d+) deg, "
                  r"([-\d.]+) m\): (\d+) points, ([\d.]+) % in plane", rev)
    assert r and float(r.group(1)) >= 80.0 and abs(float(r.group(3)) - 1.13) < 0.03, rev
    assert int(r.group(4)) == int(f.group(6)) and float(r.group(5)) >= 80.0, rev
    assert float(f.group(7)) >= 86.0 and float(r.group(5)) >= 89.0, (grouped, rev)
    assert abs(float(r.group(5)) - float(f.group(7))) <= 4.0, (grouped, rev)


@pytest.mark.skipif(not os.path.exists(os.path.join(SHARED, "cardboard_box.bag")),
                    reason="../shared/data/real/tilting_lidar_scanner is absent: the real recording is skipped")
def test_cardboard_box_gives_its_four_faces(tmp_path):
    # The laser inside a box: lines 0.04 degrees apart, 0.2 mm on its walls,
    # against 1 cm of range noise. Its bottom, front and two sides are planes;
    # its largest side holds 90 % of its points in one (45.6 % before the
    # strips of lines that fix no normal stopped merging).
    out = str(tmp_path / "cardboard_box_tlp.bag")
    run(sys.executable, IMPORT, os.path.join(SHARED, "cardboard_box.bag"), out)
    grouped = run(os.path.join(BIN, "group_bag"), out, "--urdf", out[:-4] + ".urdf", "--room")
    # The first sweep (the recording's end closes a second one, sweeping back).
    first = grouped.split("sweep 1:")[0]
    normals = [tuple(float(v) for v in p) for p in
               re.findall(r"plane \d+: \d+ points, [\d.]+ m\^2, normal \(([-\d.]+) ([-\d.]+) ([-\d.]+)\)", first)]
    for axis in ((0, 0, 1), (1, 0, 0), (0, 1, 0)):
        assert any(abs(sum(a * b for a, b in zip(n, axis))) > math.cos(math.radians(12)) for n in normals), grouped
    assert sum(1 for n in normals if abs(n[1]) > math.cos(math.radians(12))) == 2, grouped
    w = re.search(r"largest wall \(normal (\d+) deg, [-\d.]+ m\): (\d+) points, ([\d.]+) % in plane", first)
    assert w and float(w.group(3)) >= 90.0, grouped
    # The same with its lines reversed: the same side, as whole within 1 %
    # (87.2 %, and another side judged the largest, while two planes through
    # the lines' own origins, their scan planes' envelope, took the side's
    # points beside the laser: 144,000 points).
    rev = run(os.path.join(BIN, "group_bag"), out, "--urdf", out[:-4] + ".urdf", "--room", "--reverse")
    r = re.search(r"largest wall \(normal (\d+) deg, [-\d.]+ m\): (\d+) points, ([\d.]+) % in plane",
                  rev.split("sweep 1:")[0])
    assert r and r.group(1) == w.group(1) and abs(float(r.group(3)) - float(w.group(3))) <= 1.0, (grouped, rev)
    # The second sweep starts at the reversal: its first 200 lines lie within
    # 2 cm of each other, a strip that fixes no normal and took the bottom and
    # the wall beside it alike. Its segments join the planes beside it, so the
    # bottom is as whole whichever way the lines come (24.2 % forward, 57.6 %
    # reversed before; 62.6 and 57.6 % since).
    for extra in ([], ["--reverse"]):
        text = rev if extra else grouped
        second = text.split("sweep 1:")[1]
        f = re.search(r"floor at z=[-\d.]+ m: \d+ points, ([\d.]+) % in plane", second)
        assert f and float(f.group(1)) >= 55.0, (extra, text)


@pytest.mark.skipif(not os.path.exists(os.path.join(SHARED, "first_scan.bag")),
                    reason="../shared/data/real/tilting_lidar_scanner is absent: the real recording is skipped")
def test_first_scan_holds_its_table_top_and_wall_whichever_way_the_lines_come(tmp_path):
    # The stand's first test scan: a table top 17 cm below the laser (the
    # lowest level, seen 0.14-0.7 m away) and a wall 1.47 m away. The table
    # top's largest plane holds 60 % of it (its near pieces tilt by the
    # laser's own near-range bias: doc/notes/noise_model.md), the same within
    # 1 % with the lines reversed. The wall is two surfaces 3 cm apart; its
    # largest plane holds 47 % of its points forward (a strip fitted 17
    # degrees off it holds 15,000: the judge counted them out until the
    # thirteenth session and said 87 %) and 75 % reversed (48.5 and 65.6 %
    # since the split compares a run's pieces' own lines; sweep 1's went 50.7
    # -> 84.6 % forward, and reversed another wall is judged the largest).
    out = str(tmp_path / "first_scan_tlp.bag")
    run(sys.executable, IMPORT, os.path.join(SHARED, "first_scan.bag"), out)
    shares = {}
    for extra in ([], ["--reverse"]):
        text = run(os.path.join(BIN, "group_bag"), out, "--urdf", out[:-4] + ".urdf", "--room", *extra)
        first = text.split("sweep 1:")[0]
        f = re.search(r"floor at z=([-\d.]+) m: \d+ points, ([\d.]+) % in plane .* largest wall \(normal (\d+) deg, "
                      r"([-\d.]+) m\): \d+ points, ([\d.]+) % in plane", first)
        assert f and abs(float(f.group(4)) - 1.47) < 0.03, text
        shares[tuple(extra)] = (float(f.group(2)), float(f.group(5)))
    fwd, rev = shares[()], shares[("--reverse",)]
    assert fwd[0] >= 60.0 and abs(fwd[0] - rev[0]) <= 1.0, shares
    assert min(fwd[1], rev[1]) >= 45.0, shares


def test_a_spinning_heads_recording_grouped_each_half_turn(tmp_path):
    # make_scene_bag --spin: the stairs seen by the spinning head (config/head_spin.yaml, head_spin_joint of
    # urdf/hrp4_head_spin.urdf) at 1 rad/s for 10 s; group_bag --spin-span pi cuts a sweep each half turn:
    # 125 lines of 40 Hz scans, the floor one plane at z = 0 and a tread at its height (0.15 m a step).
    bag = str(tmp_path / "spin.bag")
    run(os.path.join(BIN, "make_scene_bag"), "--scene", "stairs", "--out", bag, "--duration", "10", "--spin", "1.0")
    urdf = os.path.join(ROOT, "urdf", "hrp4_head_spin.urdf")
    out = run(os.path.join(BIN, "group_bag"), bag, "--urdf", urdf, "--joint", "head_spin_joint", "--spin-span",
              str(math.pi))
    sweeps = re.findall(r"sweep (\d+): (\d+) lines, (\d+) planes", out)
    assert len(sweeps) >= 2, out
    for _, lines, planes in sweeps[:2]:  # the last, cut by the recording's end, is shorter
        assert abs(int(lines) - 125.7) <= 1.5, out
        assert int(planes) >= 10, out
    first = out.split("sweep 1:")[0]
    level = [float(m.group(1)) for m in re.finditer(r"normal \([-\d.]+ [-\d.]+ 1\.000\), offset ([-\d.]+) m", first)]
    assert any(abs(z) < 0.005 for z in level), first
    assert any(abs(z - 0.15 * k) < 0.01 for z in level for k in (1, 2, 3, 4)), first
    # A span beyond a whole turn is refused with the reason.
    bad = subprocess.run([os.path.join(BIN, "group_bag"), bag, "--urdf", urdf, "--joint", "head_spin_joint",
                          "--spin-span", "7"], capture_output=True, text=True, timeout=120)
    assert bad.returncode != 0 and "spin_span" in bad.stderr, bad.stdout + bad.stderr


def test_a_spinning_heads_recording_calibrates_with_its_span(tmp_path):
    # The spinning head's stamps 5 ms late (make_scene_bag --time-offset-ms 5). Without --spin-span no sweep
    # begins, and group_bag and calibrate say what to give; with it, calibrate holds the time offset (the
    # head turns one way: a late stamp is a joint offset of 1 rad/s x 5 ms = 0.286 deg) and finds that.
    bag = str(tmp_path / "spin.bag")
    run(os.path.join(BIN, "make_scene_bag"), "--scene", "stairs", "--out", bag, "--duration", "10", "--spin", "1.0",
        "--time-offset-ms", "5")
    urdf = os.path.join(ROOT, "urdf", "hrp4_head_spin.urdf")
    args = [bag, "--urdf", urdf, "--joint", "head_spin_joint"]
    grouped = run(os.path.join(BIN, "group_bag"), *args)
    assert "no sweep: the tilt never reversed" in grouped and "--spin-span" in grouped, grouped
    bad = subprocess.run([os.path.join(BIN, "calibrate"), *args, "--out", str(tmp_path / "x.yaml")],
                         capture_output=True, text=True, timeout=300)
    assert bad.returncode != 0 and "never reversed" in bad.stderr and "--spin-span" in bad.stderr, bad.stderr
    cal = subprocess.run([os.path.join(BIN, "calibrate"), *args, "--spin-span", str(math.pi), "--out",
                          str(tmp_path / "spin.yaml")], capture_output=True, text=True, timeout=300)
    assert cal.returncode == 0, cal.stdout + cal.stderr
    text = cal.stdout + cal.stderr
    assert "time_offset held: sweeps in one direction only" in text, text
    # Its laser's y axis is not the spin axis: a mount pitch is not a joint offset there, and is said so.
    assert "mount pitch (about the tilt axis) is the same as a joint offset" not in text, text
    assert "a mount pitch (about the laser's y axis, not the joint's axis here) is not estimated" in text, text
    m = re.search(r"joint_offset_deg=([-\d.]+) joint_offset_deg_se=([\d.]+)", text)
    assert m and abs(float(m.group(1)) + 0.286) < 0.05, text
