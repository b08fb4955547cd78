#!/usr/bin/env python3
"""Load: the pipeline on the emulated head (sim.launch) in three phases of
SECONDS each - as is; with a slow subscriber (0.2 s per message) on /scan and
/sweep_cloud; and with, in addition, both cores kept busy by two spinning
processes. Prints per phase what arrives at a quick subscriber and how late
(scan age: arrival minus the end of the scan; sweep age: arrival minus the
sweep's end), what the slow subscriber got (the rest was dropped by the
publishers' bounded queues, not queued), and the nodelets' counters of lost
or dropped messages (diagnostics).

usage: bench_load.py [--seconds 20]   (workspace sourced, /usr/bin first on PATH)
"""
import argparse
import multiprocessing
import os
import random
import signal
import subprocess
import sys
import threading
import time


def spin(stop):
    while not stop.is_set():
        pass


def slow_worker(out_path):
    """A separate node (rospy serves one topic's subscribers in one thread):
    0.2 s per message on /scan and /sweep_cloud, queues of 2; writes its counts
    to out_path every second."""
    import rospy
    from sensor_msgs.msg import LaserScan, PointCloud2
    rospy.init_node("bench_load_slow", anonymous=True)
    counts = {"scans": 0, "clouds": 0, "seq": 0}

    def slow(key):
        def cb(m):
            time.sleep(0.2)
            counts[key] += 1
            if key == "scans":
                counts["seq"] = m.header.seq
        return cb
    rospy.Subscriber("/scan", LaserScan, slow("scans"), queue_size=2)
    rospy.Subscriber("/sweep_cloud", PointCloud2, slow("clouds"), queue_size=2)
    while not rospy.is_shutdown():
        with open(out_path + ".tmp", "w") as f:
            f.write(f"{counts['scans']} {counts['clouds']} {counts['seq']}\n")
        os.replace(out_path + ".tmp", out_path)
        time.sleep(1.0)


def read_slow(path):
    """(scans, clouds, seq of the last scan) the slow subscriber has taken."""
    try:
        a, b, c = open(path).read().split()
        return int(a), int(b), int(c)
    except (OSError, ValueError):
        return 0, 0, 0


def percentile(v, p):
    if not v:
        return float("nan")
    v = sorted(v)
    return v[min(len(v) - 1, int(p / 100.0 * len(v)))]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--seconds", type=float, default=20.0)
    ap.add_argument("--slow-worker", metavar="OUT", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.slow_worker:
        return slow_worker(args.slow_worker)
    port = 16000 + random.randrange(1000)
    os.environ["ROS_MASTER_URI"] = f"http://localhost:{port}"
    log = open(f"/tmp/tlp_load_{port}.log", "w")
    launch = subprocess.Popen(["roslaunch", "-p", str(port), "tilt_laser_perception", "sim.launch",
                               f"port:={port + 1000}", f"servo_link:=/tmp/tlp_load_servo_{port}"],
                              stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
    hogs = []
    stop = multiprocessing.Event()
    try:
        time.sleep(6)
        import rospy
        from diagnostic_msgs.msg import DiagnosticArray
        from sensor_msgs.msg import LaserScan
        from tilt_laser_perception.msg import PlanePolygonArray
        rospy.init_node("bench_load", anonymous=True, disable_signals=True)
        lock = threading.Lock()
        st = {"scan_age": [], "sweep_age": [], "scans": 0, "sweeps": 0, "slow_scans": 0, "slow_clouds": 0, "diag": {},
              "seq": 0}

        def on_scan(m):
            now = rospy.Time.now().to_sec()
            end = m.header.stamp.to_sec() + m.time_increment * (len(m.ranges) - 1)
            with lock:
                st["scans"] += 1
                st["seq"] = m.header.seq
                st["scan_age"].append(1e3 * (now - end))

        def on_planes(m):
            now = rospy.Time.now().to_sec()
            with lock:
                st["sweeps"] += 1
                st["sweep_age"].append(1e3 * (now - m.header.stamp.to_sec()))

        def on_diag(m):
            with lock:
                for s in m.status:
                    st["diag"][s.name.split(": ")[-1]] = {kv.key: kv.value for kv in s.values}

        rospy.Subscriber("/scan", LaserScan, on_scan, queue_size=50, tcp_nodelay=True)
        rospy.Subscriber("/planes", PlanePolygonArray, on_planes, queue_size=10)
        rospy.Subscriber("/diagnostics", DiagnosticArray, on_diag, queue_size=20)
        time.sleep(3)

        def counters():
            d = st["diag"]
            g = lambda s, k: float(d.get(s, {}).get(k, "nan"))
            return {"published": g("laser", "scans"),
                    "splitter missed": g("scan splitter", "scans missed upstream (sequence gaps)"),
                    "grouper missed": g("sweep grouper", "scans missed upstream (sequence gaps)"),
                    "sweeps": g("sweep grouper", "sweeps published"),
                    "sweeps dropped": g("sweep grouper", "sweeps dropped")}

        rows = []
        slow_out = f"/tmp/tlp_load_slow_{port}.txt"
        for phase in ("as is", "slow subscriber", "slow subscriber, both cores busy"):
            if phase == "slow subscriber":
                slow_proc = subprocess.Popen([sys.executable, os.path.abspath(__file__), "--slow-worker", slow_out],
                                             stdout=log, stderr=subprocess.STDOUT)
                hogs.append(slow_proc)
            if phase.endswith("busy"):
                spinners = [multiprocessing.Process(target=spin, args=(stop,)) for _ in range(2)]
                for h in spinners:
                    h.start()
                hogs += spinners
            time.sleep(2)
            with lock:
                for k in ("scan_age", "sweep_age"):
                    st[k] = []
                for k in ("scans", "sweeps"):
                    st[k] = 0
                c0 = counters()
                seq0 = st["seq"]
            slow0 = read_slow(slow_out)
            time.sleep(args.seconds)
            time.sleep(1.2)  # the last diagnostics of the phase
            slow1 = read_slow(slow_out)
            with lock:
                c1 = counters()
                st["slow_scans"], st["slow_clouds"] = slow1[0] - slow0[0], slow1[1] - slow0[1]
                st["slow_span"] = slow1[2] - slow0[2]
                c1["published"] = st["seq"] - seq0  # the driver numbers its scans: the span the quick subscriber saw
                c0["published"] = 0
                rows.append((phase, dict(st), {k: c1[k] - c0[k] for k in c1}))
        stop.set()
    finally:
        stop.set()
        for h in hogs:
            if isinstance(h, subprocess.Popen):
                h.terminate()
                h.wait(10)
            else:
                h.join(5)
        if launch.poll() is None:
            os.killpg(launch.pid, signal.SIGINT)
            launch.wait(30)
    print(f"load: the pipeline on the emulated head, {args.seconds:g} s per phase (40 Hz scans, ~1.1 sweeps/s)")
    for phase, s, c in rows:
        pub = c["published"]
        print(f"  {phase}:")
        print(f"    scans published {pub:.0f}; quick subscriber got {s['scans']} "
              f"({100.0 * (1 - s['scans'] / pub) if pub else float('nan'):.1f} % lost), age after the scan's end "
              f"p50 {percentile(s['scan_age'], 50):.1f} ms, p99 {percentile(s['scan_age'], 99):.1f} ms, "
              f"max {max(s['scan_age'] or [float('nan')]):.1f} ms")
        print(f"    sweeps published {c['sweeps']:.0f}, dropped {c['sweeps dropped']:.0f}; age after the sweep's end "
              f"p50 {percentile(s['sweep_age'], 50):.1f} ms, max {max(s['sweep_age'] or [float('nan')]):.1f} ms")
        if phase != "as is":
            span = s.get("slow_span", 0)
            print(f"    slow subscriber (0.2 s per message, queue 2) got {s['slow_scans']} of {span} scans "
                  f"({100.0 * (1 - s['slow_scans'] / span) if span else float('nan'):.1f} % dropped by the publisher's "
                  f"bounded queue, none queued up) and {s['slow_clouds']} sweep clouds")
        print(f"    scans missed upstream: splitter {c['splitter missed']:.0f}, grouper {c['grouper missed']:.0f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
