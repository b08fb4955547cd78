"""Record, then replay: sim.launch record:=true records the raw topics and the
live planes of the emulated head; replay.launch re-runs the splitter and the
grouper on that bag; the replayed planes equal the live ones, sweep by sweep.

Run by ctest (CMakeLists.txt); by hand: python3 -m pytest test/test_record_replay.py
(with the workspace sourced)."""
import glob
import os
import random
import signal
import subprocess
import tempfile
import time

import rosbag

LIVE_SECONDS = 16.0  # about 16 sweeps at 1 rad/s over 10..60 deg
LAUNCH = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "launch")


def roslaunch(port, launch_file, *args, log):
    # the file by its path: under ctest the package is found both in the source and the install space
    env = dict(os.environ, ROS_MASTER_URI=f"http://localhost:{port}")
    return subprocess.Popen(["roslaunch", "-p", str(port), os.path.join(LAUNCH, launch_file), *args], env=env,
                            stdout=log, stderr=subprocess.STDOUT, start_new_session=True)


def stop(proc, timeout=20):
    if proc.poll() is None:
        os.killpg(proc.pid, signal.SIGINT)
        try:
            proc.wait(timeout)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()


def replay_recorded(port, bag, out_bag, topics, log, *args, duration=None):
    """replay.launch bag:=BAG ARGS on its own master, its outputs TOPICS recorded to OUT_BAG; returns when the bag
    has played (replay.launch waits 1 s, then plays at rate 1) and a few seconds more."""
    replay = roslaunch(port, "replay.launch", f"bag:={bag}", *args, log=log)
    env = dict(os.environ, ROS_MASTER_URI=f"http://localhost:{port}")
    rec = None
    try:
        time.sleep(0.5)
        rec = subprocess.Popen(["rosbag", "record", "-O", out_bag, *topics], env=env, stdout=log,
                               stderr=subprocess.STDOUT, start_new_session=True)
        if duration is None:
            with rosbag.Bag(bag) as b:
                duration = b.get_end_time() - b.get_start_time()
        time.sleep(duration + 5.0)
    finally:
        if rec:
            stop(rec)
        stop(replay)


def planes_by_stamp(bag_path, topic):
    out = {}
    with rosbag.Bag(bag_path) as bag:
        for _, msg, _ in bag.read_messages(topics=[topic]):
            out[msg.header.stamp.to_nsec()] = msg
    return out


def same_planes(a, b):
    """Equal within float rounding: same planes in the same order, same members."""
    if len(a.planes) != len(b.planes):
        return f"{len(a.planes)} planes live, {len(b.planes)} replayed"
    for p, q in zip(a.planes, b.planes):
        if (p.id, p.point_count, p.segment_count) != (q.id, q.point_count, q.segment_count):
            return f"plane {p.id}: members {p.point_count}/{p.segment_count} live, {q.point_count}/{q.segment_count}"
        d = max(abs(p.normal.x - q.normal.x), abs(p.normal.y - q.normal.y), abs(p.normal.z - q.normal.z),
                abs(p.offset - q.offset), abs(p.area - q.area))
        if d > 1e-6:
            return f"plane {p.id}: parameters differ by {d:g}"
        if len(p.boundary.points) != len(q.boundary.points):
            return f"plane {p.id}: outline of {len(p.boundary.points)} vertices live, {len(q.boundary.points)} replayed"
    return ""


def record_and_replay(live_seconds, min_compared, live_args=(), replay_args=()):
    work = tempfile.mkdtemp(prefix="tlp_record_replay_")
    port = 12000 + random.randrange(2000)
    with open(os.path.join(work, "live.log"), "w") as log:
        live = roslaunch(port, "sim.launch", f"port:={port + 3000}", f"servo_link:={work}/servo", "record:=true",
                         "record_outputs:=true", f"bag_prefix:={work}/live", *live_args, log=log)
        try:
            time.sleep(live_seconds)
        finally:
            stop(live)
    bags = glob.glob(os.path.join(work, "live_*.bag"))
    assert len(bags) == 1, f"no recording in {work}: {os.listdir(work)}"
    live_planes = planes_by_stamp(bags[0], "/planes")
    assert len(live_planes) >= min_compared + 3, f"only {len(live_planes)} live sweeps recorded"

    with open(os.path.join(work, "replay.log"), "w") as log:
        replay_recorded(port + 1, bags[0], os.path.join(work, "replay.bag"), ["/planes"], log, *replay_args)
    replayed = planes_by_stamp(os.path.join(work, "replay.bag"), "/planes")
    common = sorted(set(live_planes) & set(replayed))
    # The recording began after the first live sweep had, and it stopped
    # within the last one: the joint states and transforms after the bag's
    # end are missing, so the replay may finish that sweep without its last
    # line (seen once in CI: 32689 points replayed against 33561 live, every
    # earlier sweep equal). Compare the sweeps in between.
    compared = common[1:-1]
    print(f"live sweeps {len(live_planes)}, replayed {len(replayed)}, compared {len(compared)}")
    assert len(compared) >= min_compared, f"live {len(live_planes)}, replayed {len(replayed)}, common {len(common)}"
    # every replayed sweep after the first has its live twin
    assert len(replayed) - len(common) <= 1, "replayed sweeps with no live twin"
    diffs = {t: same_planes(live_planes[t], replayed[t]) for t in compared}
    bad = {t: d for t, d in diffs.items() if d}
    assert not bad, f"{len(bad)} of {len(compared)} sweeps differ: {bad}"


def test_replayed_planes_equal_the_live_ones():
    record_and_replay(LIVE_SECONDS, 7)


def test_a_spinning_heads_replayed_planes_equal_the_live_ones():
    # A sweep each half turn at 1 rad/s (3.1 s): about 8 in 30 s after the head's start.
    record_and_replay(30.0, 4, ["spin:=1.0"], ["spin:=true"])
