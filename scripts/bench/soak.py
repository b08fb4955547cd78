#!/usr/bin/env python3
"""Soak: the emulated head with the whole pipeline (sim.launch) for MINUTES,
with laser and servo faults injected at random moments (tilt_laser_sim
--fault). Checks and prints:
- the nodelet manager's resident memory after the warm-up and at the end
  (growth under 5 MB);
- that no scan, joint state or sweep is published twice or out of order;
- that every injected fault shows in the driver's diagnostics counters.
Exits 1 when a check fails.

usage: soak.py [--minutes 30] [--seed 1] [--every 45] [--warmup 120]
(needs the workspace sourced; PATH with /usr/bin first)
"""
import argparse
import os
import random
import signal
import subprocess
import sys
import threading
import time

# fault -> (tilt_laser_sim spec with {t}, diagnostics status, counter, increase it gives at least)
FAULTS = {
    "drop": ("drop@{t}", "laser", "connections", 1),
    "silent": ("silent@{t}:2", "laser", "watchdog timeouts", 1),
    "corrupt": ("corrupt@{t}:3", "laser", "checksum errors", 3),
    "truncate": ("truncate@{t}:2", "laser", "truncated scans", 2),
    "reboot": ("reboot@{t}", "laser", "sensor restarts (clock started again)", 1),
    "servo-noreply": ("servo-noreply@{t}:0.5", "tilt servo", "timeouts", 1),
    "servo-badcrc": ("servo-badcrc@{t}:3", "tilt servo", "bad packets", 3),
    "servo-garbage": ("servo-garbage@{t}:3", "tilt servo", "garbage bytes", 1),
    "servo-overload": ("servo-overload@{t}", "tilt servo", "hardware error events", 1),
    "servo-vanish": ("servo-vanish@{t}:2", "tilt servo", "port reopens", 1),
}


def rss_mb(pid):
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith("VmRSS"):
                return int(line.split()[1]) / 1024.0
    return float("nan")


def child_pid(parent, pattern):
    out = subprocess.run(["pgrep", "-P", str(parent), "-f", pattern], capture_output=True, text=True).stdout.split()
    return int(out[0]) if out else None


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--minutes", type=float, default=30.0)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--every", type=float, default=45.0, help="mean seconds between faults")
    ap.add_argument("--warmup", type=float, default=120.0)
    args = ap.parse_args()
    duration = args.minutes * 60.0
    rng = random.Random(args.seed)
    # the schedule: after the warm-up, a random fault at random gaps; a hardware
    # error is cleared 1 s later (the driver then recovers the servo)
    plan, t = [], args.warmup
    while True:
        t += rng.uniform(0.5, 1.5) * args.every
        if t > duration - 20:
            break
        plan.append((round(t, 1), rng.choice(sorted(FAULTS))))
    specs = []
    for t, name in plan:
        specs.append(FAULTS[name][0].format(t=t))
        if name == "servo-overload":
            specs.append(f"servo-clear@{t + 1.0:.1f}")
    port = 14000 + rng.randrange(1000)
    env = dict(os.environ, ROS_MASTER_URI=f"http://localhost:{port}")
    os.environ["ROS_MASTER_URI"] = env["ROS_MASTER_URI"]
    faults = " ".join(f"--fault {s}" for s in specs)
    log = open(f"/tmp/tlp_soak_{port}.log", "w")
    launch = subprocess.Popen(["roslaunch", "-p", str(port), "tilt_laser_perception", "sim.launch",
                               f"port:={port + 1000}", f"servo_link:=/tmp/tlp_soak_servo_{port}", f"faults:={faults}"],
                              env=env, stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
    print(f"soak: {args.minutes:g} min, {len(plan)} faults ({', '.join(n for _, n in plan[:6])}...), "
          f"log /tmp/tlp_soak_{port}.log", flush=True)
    try:
        time.sleep(5)
        import rospy
        from diagnostic_msgs.msg import DiagnosticArray
        from sensor_msgs.msg import JointState, LaserScan
        from tilt_laser_perception.msg import PlanePolygonArray
        rospy.init_node("soak_monitor", anonymous=True, disable_signals=True)
        lock = threading.Lock()
        state = {"diag": {}, "last": {}, "count": {}, "dup": {}, "back": {}}

        def order(kind, stamp):
            with lock:
                s = stamp.to_nsec()
                last = state["last"].get(kind)
                state["count"][kind] = state["count"].get(kind, 0) + 1
                if last is not None and s == last:
                    state["dup"][kind] = state["dup"].get(kind, 0) + 1
                elif last is not None and s < last:
                    state["back"][kind] = state["back"].get(kind, 0) + 1
                state["last"][kind] = max(s, last or 0)

        def on_diag(msg):
            with lock:
                for st in msg.status:
                    state["diag"][st.name.split(": ")[-1]] = {kv.key: kv.value for kv in st.values}

        def on_joint(msg):
            if "head_tilt_joint" in msg.name:
                order("joint state", msg.header.stamp)

        rospy.Subscriber("/scan", LaserScan, lambda m: order("scan", m.header.stamp), queue_size=100)
        rospy.Subscriber("/joint_states", JointState, on_joint, queue_size=500)
        rospy.Subscriber("/planes", PlanePolygonArray, lambda m: order("sweep", m.header.stamp), queue_size=10)
        rospy.Subscriber("/diagnostics", DiagnosticArray, on_diag, queue_size=10)
        manager = None
        while manager is None and launch.poll() is None:
            manager = child_pid(launch.pid, "nodelet manager")
            time.sleep(0.5)
        start = time.monotonic()
        rss = []
        baseline = None
        while time.monotonic() - start < duration and launch.poll() is None:
            time.sleep(10)
            el = time.monotonic() - start
            rss.append((el, rss_mb(manager)))
            if len(rss) > 1 and rss[-1][1] - rss[-2][1] > (0.0 if os.environ.get("SOAK_VERBOSE") else 1.0):
                near = [f"{n}@{t:g}" for t, n in plan if el - 15 <= t <= el]
                print(f"  {el:6.0f} s: resident +{rss[-1][1] - rss[-2][1]:.1f} MB to {rss[-1][1]:.1f} MB "
                      f"(faults in the last 15 s: {', '.join(near) or 'none'})", flush=True)
            if baseline is None and el >= args.warmup:
                baseline = rss[-1][1]
                with lock:
                    base_diag = {k: dict(v) for k, v in state["diag"].items()}
            if int(el) % 300 < 10:
                with lock:
                    print(f"  {el / 60:5.1f} min: rss {rss[-1][1]:.1f} MB, scans {state['count'].get('scan', 0)}, "
                          f"sweeps {state['count'].get('sweep', 0)}", flush=True)
        time.sleep(2)
        with lock:
            diag = {k: dict(v) for k, v in state["diag"].items()}
            counts, dups, backs = dict(state["count"]), dict(state["dup"]), dict(state["back"])
    finally:
        if launch.poll() is None:
            os.killpg(launch.pid, signal.SIGINT)
            launch.wait(30)
    if baseline is None:
        print(f"soak: the run ended before the {args.warmup:.0f} s warm-up was over (see the log): FAIL")
        return 1
    ok = True
    print(f"soak over {args.minutes:g} min of real time (the emulator runs at the sensor's own rate):")
    growth = rss[-1][1] - baseline if baseline is not None and rss else float("nan")
    good = growth < 5.0
    ok &= good
    print(f"  nodelet manager resident: {baseline:.1f} MB after {args.warmup:.0f} s warm-up, {rss[-1][1]:.1f} MB at the "
          f"end, max {max(r for _, r in rss):.1f} MB: growth {growth:+.2f} MB (bound 5)  {'ok' if good else 'FAIL'}")
    for kind in ("scan", "joint state", "sweep"):
        d, b = dups.get(kind, 0), backs.get(kind, 0)
        ok &= d == 0 and b == 0 and counts.get(kind, 0) > 0
        print(f"  {kind}s: {counts.get(kind, 0)} received, {d} twice, {b} out of order  "
              f"{'ok' if d == 0 and b == 0 and counts.get(kind, 0) else 'FAIL'}")
    injected = {}
    for _, name in plan:
        injected[name] = injected.get(name, 0) + 1
    print("  faults injected after the warm-up, and the driver's counters over the same time:")
    for name in sorted(injected):
        _, status, key, per = FAULTS[name]
        try:
            delta = float(diag[status][key]) - float(base_diag[status][key])
        except (KeyError, ValueError):
            delta = float("nan")
        good = delta >= per * injected[name]
        ok &= good
        print(f"    {name:15s} x{injected[name]:2d}: '{status}: {key}' +{delta:g} (at least {per * injected[name]})  "
              f"{'ok' if good else 'FAIL'}")
    print("soak: " + ("PASS" if ok else "FAIL"))
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
