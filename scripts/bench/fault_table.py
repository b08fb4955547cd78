#!/usr/bin/env python3
"""Fault table: the emulated head with the whole pipeline (sim.launch), every
fault the emulator has at a known time, one after another (GAP seconds
apart). For each fault it prints the longest gap in the scans and in the
tilt joint states around it, the time back to the normal rate after the
fault's end (gap end minus fault end; an instant fault ends when it
strikes), the sweeps published late (planes more than 1 s after their
stamp) or partial (more than 10 % of the lines its span should hold missing),
and, for the whole run, any scan, joint state or sweep received twice or out
of order. Exits 1 when a fault is not back within 2 s, or a sweep was late,
partial, twice or out of order.

usage: fault_table.py [--gap 14] [--first 20]
(needs the workspace sourced; PATH with /usr/bin first)
"""
import argparse
import os
import signal
import statistics
import subprocess
import sys
import threading
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from soak import child_pid  # noqa: E402

# name, tilt_laser_sim specs (t: the fault's time), its duration [s], the stream it hits
FAULTS = [
    ("drop", ["drop@{t}"], 0.0, "scan"),
    ("silent 2 s", ["silent@{t}:2"], 2.0, "scan"),
    ("silent 6 s", ["silent@{t}:6"], 6.0, "scan"),
    ("corrupt x3", ["corrupt@{t}:3"], 0.0, "scan"),
    ("truncate x2", ["truncate@{t}:2"], 0.0, "scan"),
    ("delay 300 ms, 4 s", ["delay@{t}:300", "delay@{t4}:0"], 4.0, "scan"),
    # the UTM-30LX is unreachable for its start-up time ("within 10 sec"), the emulator's default
    ("reboot (10 s to boot)", ["reboot@{t}"], 10.0, "scan"),
    ("servo no reply 0.5 s", ["servo-noreply@{t}:0.5"], 0.5, "joint"),
    ("servo bad CRC x20", ["servo-badcrc@{t}:20"], 0.0, "joint"),
    ("servo garbage x3", ["servo-garbage@{t}:3"], 0.0, "joint"),
    ("servo overload", ["servo-overload@{t}", "servo-clear@{t1}"], 1.0, "joint"),
    ("servo vanish 2 s", ["servo-vanish@{t}:2"], 2.0, "joint"),
]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--gap", type=float, default=14.0, help="seconds between faults (more than the 10 s reboot)")
    ap.add_argument("--first", type=float, default=20.0, help="the first fault's time after the start")
    args = ap.parse_args()
    plan, specs = [], []
    for i, (name, spec, dur, stream) in enumerate(FAULTS):
        t = args.first + i * args.gap
        plan.append((name, t, dur, stream))
        specs += [s.format(t=t, t1=t + 1.0, t4=t + 4.0) for s in spec]
    duration = args.first + len(FAULTS) * args.gap + 5.0
    port = 15000 + os.getpid() % 1000
    env = dict(os.environ, ROS_MASTER_URI=f"http://localhost:{port}")
    os.environ["ROS_MASTER_URI"] = env["ROS_MASTER_URI"]
    log = open(f"/tmp/tlp_faults_{port}.log", "w")
    faults = " ".join(f"--fault {s}" for s in specs)
    launch = subprocess.Popen(["roslaunch", "-p", str(port), "tilt_laser_perception", "sim.launch",
                               f"port:={port + 1000}", f"servo_link:=/tmp/tlp_faults_servo_{port}",
                               f"faults:={faults}"],
                              env=env, stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
    print(f"fault table: {len(FAULTS)} faults {args.gap:g} s apart, {duration:.0f} s; log /tmp/tlp_faults_{port}.log",
          flush=True)
    try:
        time.sleep(3)
        import rospy
        from sensor_msgs.msg import JointState, LaserScan, PointCloud2
        from tilt_laser_perception.msg import PlanePolygonArray
        rospy.init_node("fault_table", anonymous=True, disable_signals=True)
        lock = threading.Lock()
        arrivals = {"scan": [], "joint": []}
        sweeps, clouds = [], []  # (arrival, stamp); (arrival, lines)
        order = {"scan": [0, 0, None], "joint": [0, 0, None], "sweep": [0, 0, None]}  # twice, back, last

        def seen(kind, stamp):
            s = stamp.to_nsec()
            o = order[kind]
            if o[2] is not None and s == o[2]:
                o[0] += 1
            elif o[2] is not None and s < o[2]:
                o[1] += 1
            o[2] = max(s, o[2] or 0)

        def on_scan(m):
            with lock:
                arrivals["scan"].append(time.monotonic())
                seen("scan", m.header.stamp)

        def on_joint(m):
            if "head_tilt_joint" in m.name:
                with lock:
                    arrivals["joint"].append(time.monotonic())
                    seen("joint", m.header.stamp)

        def on_planes(m):
            with lock:
                sweeps.append((rospy.Time.now().to_sec(), m.header.stamp.to_sec()))
                seen("sweep", m.header.stamp)

        from sensor_msgs import point_cloud2

        def on_cloud(m):
            # the sweep's own span: its last line's time since the sweep's start
            last = [p[0] for p in point_cloud2.read_points(m, field_names=("time",),
                                                           uvs=[(0, m.height - 1)])] if m.height else [0.0]
            with lock:
                clouds.append((time.monotonic(), last[0], m.height))

        rospy.Subscriber("/scan", LaserScan, on_scan, queue_size=200)
        rospy.Subscriber("/joint_states", JointState, on_joint, queue_size=1000)
        rospy.Subscriber("/planes", PlanePolygonArray, on_planes, queue_size=20)
        rospy.Subscriber("/sweep_cloud", PointCloud2, on_cloud, queue_size=5)
        # The emulator's clock starts with the launch; its start is told by its
        # own log line, or else estimated from the first scan.
        sim = None
        while sim is None and launch.poll() is None:
            sim = child_pid(launch.pid, "tilt_laser_sim")
            time.sleep(0.05)
        start = time.monotonic()
        with open(f"/proc/{sim}/stat") as f:  # the emulator's own start, in monotonic seconds
            start_ticks = int(f.read().rsplit(")", 1)[1].split()[19])
        start = start_ticks / os.sysconf("SC_CLK_TCK")
        while time.monotonic() - start < duration and launch.poll() is None:
            time.sleep(1.0)
        with lock:
            arr = {k: list(v) for k, v in arrivals.items()}
            sw, cl, od = list(sweeps), list(clouds), {k: list(v) for k, v in order.items()}
    finally:
        if launch.poll() is None:
            os.killpg(launch.pid, signal.SIGINT)
            launch.wait(30)
    ok = True
    usual = statistics.median(h for _, _, h in cl) if cl else 0
    # A sweep's expected lines: its span (the last line's time since the
    # sweep's start) over the line period; partial when more than 10 % of them
    # are missing (the grouper's own rule, ~max_dropped_fraction; +-1 line for
    # the span's ends).
    short = []
    for at, span, lines in cl:
        expected = span / 0.025 + 1
        short.append((at, f"{lines}/{expected:.0f}", lines < 0.9 * expected - 1))
    print(f"{'fault':24s} {'at [s]':>6s} {'gap [s]':>8s} {'back after end [s]':>19s}  late/partial sweeps")
    for name, t, dur, stream in plan:
        a = [x - start for x in arr[stream] if t - 1.0 <= x - start <= t + dur + 6.0]
        if len(a) < 2:
            print(f"{name:24s} {t:6.1f}  no data")
            ok = False
            continue
        gaps = [(a[i + 1] - a[i], a[i], a[i + 1]) for i in range(len(a) - 1)]
        g, g0, g1 = max(gaps)
        # The fault ends at t + dur by the emulator's clock; the data tells when the stream resumed.
        back = max(0.0, g1 - (t + dur)) if g > 0.1 else 0.0
        late = sum(1 for at, st in sw if t <= st - 0.0 and at - st > 1.0 and st <= t + dur + 6.0)
        partial = sum(1 for at, h, bad in short if t <= at - start <= t + dur + 6.0 and bad)
        good = back <= 2.0 and late == 0 and partial == 0
        ok &= good
        lines = [h for at, h, _ in short if t <= at - start <= t + dur + 6.0]
        print(f"{name:24s} {t:6.1f} {g:8.2f} {back:19.2f}  {late}/{partial}  {'ok' if good else 'FAIL'}"
              + ("" if partial == 0 else f"  (lines/expected of its sweeps: {', '.join(lines)})"))
    for kind in ("scan", "joint", "sweep"):
        twice, back, _ = od[kind]
        good = twice == 0 and back == 0
        ok &= good
        print(f"{kind}s: {twice} twice, {back} out of order  {'ok' if good else 'FAIL'}")
    print(f"sweeps published {len(sw)}, usual sweep {usual:.0f} lines")
    print("fault table: " + ("PASS" if ok else "FAIL"))
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
