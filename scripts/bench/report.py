#!/usr/bin/env python3
"""The evaluation report: runs the evaluations and benchmarks that README and
doc/ cite, and writes doc/evaluation.md (tables, date, commit, machine, the
command of each table) and README's table of what to expect (between its
report:summary markers). A figure changes by running this again, never by
editing text. scripts/report.sh sets up and builds first.

  report.py [--ws build_ws] [--shared ../shared] [--quick] [--no-readme]

--quick: fewer seeds and no pipeline run (a check of the script, not a report).
"""
import argparse
import datetime
import json
import os
import platform
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.abspath(os.path.join(HERE, "..", ".."))
sys.path.insert(0, HERE)
from eval_table import summarize  # noqa: E402

BEGIN = "<!-- report:summary begin (written by scripts/report.sh; do not edit) -->"
END = "<!-- report:summary end -->"


def edges(f):
    """A scene's step edges: median / p95 of those the map shows; the share it leaves unknown."""
    if f['edge_median_cm'] != f['edge_median_cm']:
        return "-"
    return f"{f['edge_median_cm']:.1f} / {f['edge_p95_cm']:.1f}; {f['edge_unknown_pct']:.1f}"


def run(cmd, **kw):
    return subprocess.run(cmd, capture_output=True, text=True, check=True, **kw).stdout


def table(header, rows):
    out = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    out += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
    return "\n".join(out)


class Report:
    def __init__(self, bin_dir, ws, shared, quick):
        self.bin, self.ws, self.shared, self.quick = bin_dir, ws, shared, quick
        self.sections = []   # (title, command, text)
        self.summary = {}
        self._calibration = None  # calibration_file()

    def tool(self, name):
        return os.path.join(self.bin, name)

    def section(self, title, command, text):
        self.sections.append((title, command, text))
        print(f"== {title}", flush=True)

    # ---- simulated scenes -------------------------------------------------
    def scenes(self):
        seeds = [1, 2] if self.quick else [1, 2, 3, 4, 5, 6]
        names = sorted(f[:-5] for f in os.listdir(os.path.join(ROOT, "config", "scenes"))
                       if f.endswith(".yaml") and not f.startswith("figure3"))
        rows, self.scene_figures = [], {}
        cal = self.calibration_file()
        for name in names:
            for rig in ([], ["--realistic"]):
                f = summarize(self.tool("evaluate"), seeds, ["--scene", name, "--sweeps", "6"] + rig)
                r = summarize(self.tool("evaluate"), seeds, ["--scene", name, "--sweeps", "6", "--reverse"] + rig)
                c = summarize(self.tool("evaluate"), seeds, ["--scene", name, "--sweeps", "6", "--calibration", cal] +
                              rig) if rig else None
                self.scene_figures[(name, bool(rig))] = f
                rows.append([name, "realistic" if rig else "ideal",
                             f"{f['correct']:.0f} / {f['true_faces']:.0f} ({100 * f['correct'] / max(f['true_faces'], 1):.1f} %)",
                             f"{f['noise']:.2f}", f"{f['missed']:.2f}", f"{f['normal_err_deg']:.2f}",
                             f"{f['rmse_cm']:.2f}", f"{f['walkable_cm']:.2f}",
                             edges(f), f"{f['invented_pct']:.2f}",
                             f"{f['step_precision_pct']:.1f} / {f['step_recall_pct']:.1f}",
                             f"{f['latency_ms']:.2f}", f"{r['correct']:.0f}, noise {r['noise']:.2f}",
                             (f"{c['walkable_cm']:.2f}; " + ("-" if c['edge_median_cm'] != c['edge_median_cm'] else
                                                             f"{c['edge_median_cm']:.1f} / {c['edge_p95_cm']:.1f}"))
                             if c else "-"])
        s = ",".join(map(str, seeds))
        self.section(
            "Planes and height map on the simulator's scenes",
            f"python3 scripts/bench/eval_table.py BIN/evaluate --seeds {s} -- --scene NAME --sweeps 6 [--realistic [--calibration CAL]] [--reverse]",
            f"Every scene of `config/scenes` (but the Figure 3 ones), seeds {s}, 6 sweeps each, sweeps at 1 rad/s over "
            "10-60 degrees; `realistic`: a real rig's errors (encoder steps, backlash, timing, mount, beam footprint; "
            "doc/simulator.md). Correct faces by Hoover et al.'s criteria at 80 % overlap, summed over the sweeps; "
            "noise and missed: planes a sweep; normal error of the correct faces; the sweep's height map against the "
            "truth, over all its cells and over those of walkable surfaces away from their edges (the true heights "
            "5 cm away along x and y within the walkable slope of 15 degrees); step edges: each centimetre of a true "
            "step edge (a rise of 5-20 cm with 3 cm flat on each side, along x or y) in view (points of two of the "
            "sweep's lines on its higher surface within 10 cm along and 5 cm across it) against where the map's "
            "higher surface ends along the same row or column, measured across the edge (each edge by the row or "
            "column nearer its normal), median and 95th percentile (10: not within 10 cm; "
            "unknown: the share of the edges in view around which the map knows no cell of the row within 10 cm, "
            "not judged; "
            "-: no step edge in view); invented: the share of the map's known "
            "cells whose true surface the sensor could not see (a ray cast to it); steppable: of the cells the map "
            "says a 0.24 x 0.14 m foot of any yaw fits, the share where it truly does (a disc of its radius on one "
            "true plane within 15 degrees), and of those where it truly does and the map knows every cell of the disc, the share found; latency: from the sweep's last line to its planes and map (median sweep); lines reversed: "
            "the same sweeps with each sweep's lines grouped last first (`--reverse`: the result should not depend "
            "on the order); calibrated: the realistic rig's walkable RMSE and step edges with the head calibrated as a user would "
            "(`make_scene_bag --scene stairs --realistic --duration 10 --seed 7`, `calibrate` on it, `evaluate "
            "--calibration` its estimate).\n\n" +
            table(["scene", "rig", "correct faces", "noise", "missed", "normal error [deg]", "height map RMSE [cm]",
                   "walkable RMSE [cm]", "step edges: median / p95 [cm]; unknown [%]", "invented [%]",
                   "steppable: precision / recall [%]", "latency [ms]",
                   "lines reversed: correct", "calibrated: walkable RMSE; step edges median / p95 [cm]"], rows))
        st, sr = self.scene_figures[("stairs", False)], self.scene_figures[("stairs", True)]
        self.summary["stairs"] = (f"{100 * st['correct'] / st['true_faces']:.0f} % of the faces, "
                                  f"height map {st['rmse_cm']:.1f} cm RMSE "
                                  f"({100 * sr['correct'] / sr['true_faces']:.0f} % and {sr['rmse_cm']:.1f} cm "
                                  "with a real rig's errors)")
        cl = self.scene_figures[("clutter", False)]
        self.summary["clutter"] = (f"{100 * cl['correct'] / cl['true_faces']:.0f} % of the faces, "
                                   f"height map {cl['rmse_cm']:.1f} cm RMSE")
        out = run([self.tool("evaluate"), "--scene", "stairs", "--sweeps", "3"])
        lines = [int(l.split(",")[1]) for l in out.splitlines() if l and l[0].isdigit()]
        self.summary["period"] = f"{statistics.median(lines) / 40.0:.2f} s ({statistics.median(lines):.0f} scans at 40 Hz)"

    def spinning(self):
        seeds = [1, 2] if self.quick else [1, 2, 3, 4, 5, 6]
        rows = []
        for name in ("stairs", "cinder_blocks"):
            nod = summarize(self.tool("evaluate"), seeds, ["--scene", name, "--sweeps", "6"])
            spin = summarize(self.tool("evaluate"), seeds, ["--scene", name, "--sweeps", "6", "--spin", "1.0"])
            for label, f in (("nodding 10-60 deg at 1 rad/s", nod), ("spinning at 1 rad/s, a half turn", spin)):
                rows.append([name, label,
                             f"{f['correct']:.0f} / {f['true_faces']:.0f} ({100 * f['correct'] / max(f['true_faces'], 1):.1f} %)",
                             f"{f['noise']:.2f}", f"{f['rmse_cm']:.2f}", f"{f['walkable_cm']:.2f}", f"{f['front']:.0f}",
                             f"{f['latency_ms']:.2f}"])
            if name == "stairs":
                self.summary["spin"] = (f"stairs: {100 * spin['correct'] / max(spin['true_faces'], 1):.0f} % of the "
                                        f"faces it sees (nodding {100 * nod['correct'] / max(nod['true_faces'], 1):.0f} %), "
                                        f"height map {spin['rmse_cm']:.1f} cm RMSE (nodding {nod['rmse_cm']:.1f}), "
                                        f"the front of the feet {spin['front']:.0f} % known (nodding {nod['front']:.0f} %)")
        s = ",".join(map(str, seeds))
        self.section("A spinning head against a nodding one",
                     f"python3 scripts/bench/eval_table.py BIN/evaluate --seeds {s} -- --scene NAME --sweeps 6 [--spin 1.0]",
                     "The same scenes, seeds and sweep count with the nodding head (config/head.yaml) and a spinning "
                     "one (`--spin 1.0`: config/head_spin.yaml, the spin axis 30 degrees down, the scan plane "
                     "containing it, a sweep each half turn: 125 lines). They see different faces (the spinning head "
                     "sees all around and the ground at its feet), so each row's correct faces are of the faces it "
                     "sees. Front: the 1 m x 1 m before the feet known in the sweep's map.\n\n" +
                     table(["scene", "head", "correct faces", "noise", "height map RMSE [cm]", "walkable RMSE [cm]",
                            "front known [%]", "latency [ms]"], rows))

    def density(self):
        # The step edges a sweep can place: an edge whose lower face the head
        # does not see lies somewhere between the last line on its higher
        # surface and the next line, whose spacing grows with range.
        seeds = [1, 2] if self.quick else [1, 2, 3, 4, 5, 6]
        rows = []
        for name in ("stairs", "open_stairs", "table_room", "clutter", "cinder_blocks"):
            for speed in ("1.0", "0.5"):
                f = summarize(self.tool("evaluate"), seeds, ["--scene", name, "--sweeps", "6", "--speed", speed])
                rows.append([name, f"{speed} rad/s ({f['lines']:.0f} lines)",
                             f"{f['correct']:.0f} / {f['true_faces']:.0f} ({100 * f['correct'] / max(f['true_faces'], 1):.1f} %)",
                             f"{f['rmse_cm']:.2f}", f"{f['walkable_cm']:.2f}",
                             edges(f)])
        s = ",".join(map(str, seeds))
        self.section("A denser sweep: where step edges are placed",
                     f"python3 scripts/bench/eval_table.py BIN/evaluate --seeds {s} -- --scene NAME --sweeps 6 "
                     "--speed RAD_PER_S",
                     "The nodding head over 10-60 degrees at 1 rad/s (the default) and at 0.5 rad/s (twice the lines, "
                     "a sweep every 1.8 s), ideal rig, seeds and figures as in the scenes' table. A step edge whose "
                     "lower face the head does not see (a box's far side) lies somewhere between the last line on its "
                     "higher surface and the next line, which the map does not claim: its error is up to the lines' "
                     "spacing there (about 7 cm at 1.4 m from the head at 1 rad/s).\n\n" +
                     table(["scene", "sweep", "correct faces", "height map RMSE [cm]", "walkable RMSE [cm]",
                            "step edges: median / p95 [cm]; unknown [%]"], rows))

    def calibration_file(self):
        # The realistic rig calibrated as a user would: calibrate on 10 s of it
        # standing before the stairs (made once; cleanup() removes it).
        if self._calibration is None:
            tmp = tempfile.mkdtemp()
            cal_bag, cal = os.path.join(tmp, "standing.bag"), os.path.join(tmp, "head_calibration.yaml")
            run([self.tool("make_scene_bag"), "--scene", "stairs", "--out", cal_bag, "--duration", "10", "--seed",
                 "7", "--realistic"])
            run([self.tool("calibrate"), cal_bag, "--out", cal])
            self._calibration = cal
        return self._calibration

    def cleanup(self):
        if self._calibration is not None:
            shutil.rmtree(os.path.dirname(self._calibration), ignore_errors=True)
            self._calibration = None

    def walking(self):
        seeds = [1] if self.quick else [1, 2, 3]
        rows = []
        walk = ["--walk", "0.3", "--start", "-1.5,0"]
        for label, args in (("walking 0.3 m/s towards the stairs", walk),
                            ("the same, realistic", walk + ["--realistic"]),
                            ("the same, realistic, calibrated", walk + ["--realistic", "--calibration",
                                                                         self.calibration_file()])):
            f = summarize(self.tool("evaluate"), seeds, ["--scene", "stairs", "--sweeps", "10"] + args)
            rows.append([label, f"{f['rmse_cm']:.2f}", f"{f['fused_rmse_cm']:.2f}", f"{f['fused_walkable_cm']:.2f}",
                         f"{f['overconfident_pct']:.1f}", f"{f['front']:.0f}", f"{f['fused_front']:.0f}",
                         f"{100 * f['correct'] / max(f['true_faces'], 1):.1f} %"])
            if "--realistic" not in args:
                self.summary["walk"] = f"fused height map {f['fused_rmse_cm']:.1f} cm RMSE"
        s = ",".join(map(str, seeds))
        self.section("Walking: the fused height map",
                     f"python3 scripts/bench/eval_table.py BIN/evaluate --seeds {s} -- --scene stairs --sweeps 10 "
                     "--walk 0.3 --start -1.5,0 [--realistic [--calibration CAL]]",
                     "The robot walks towards the stairs; every beam at the base's pose at its own time, the map "
                     "fused over sweeps; calibrated: the head calibrated as in the scenes' table. Beyond 2 sigma: of the fused map's walkable cells, the share whose error "
                     "exceeds twice the sigma its uncertainty layer states (an honest sigma: about 5 %). The front: "
                     "the 1 m before the feet, known by the sweep's own map and by the fused one, over the sweeps "
                     "after 1 m walked.\n\n" +
                     table(["run", "sweep map RMSE [cm]", "fused map RMSE [cm]", "fused walkable RMSE [cm]",
                            "beyond 2 sigma [%]", "front known, sweep [%]", "front known, fused [%]", "correct faces"],
                           rows))

    def walking_scenes(self):
        # What the map gives while the robot walks, on every scene: the
        # sweep's own map (each beam at the base's pose at its time) and the
        # fused one, against the truth.
        seeds = [1] if self.quick else [1, 2, 3, 4, 5, 6]
        names = sorted(f[:-5] for f in os.listdir(os.path.join(ROOT, "config", "scenes"))
                       if f.endswith(".yaml") and not f.startswith("figure3"))
        rows = []
        for name in names:
            for rig in ([], ["--realistic"]):
                f = summarize(self.tool("evaluate"), seeds, ["--scene", name, "--sweeps", "10", "--walk", "0.3",
                                                             "--start", "-1.5,0"] + rig)
                rows.append([name, "realistic" if rig else "ideal",
                             f"{f['correct']:.0f} / {f['true_faces']:.0f} ({100 * f['correct'] / max(f['true_faces'], 1):.1f} %)",
                             f"{f['walkable_cm']:.2f}", f"{f['fused_walkable_cm']:.2f}", edges(f),
                             f"{f['invented_pct']:.2f}", f"{f['overconfident_pct']:.1f}",
                             f"{f['step_precision_pct']:.1f} / {f['step_recall_pct']:.1f}"])
        s = ",".join(map(str, seeds))
        self.section("Walking towards every scene",
                     f"python3 scripts/bench/eval_table.py BIN/evaluate --seeds {s} -- --scene NAME --sweeps 10 "
                     "--walk 0.3 --start -1.5,0 [--realistic]",
                     "The robot starts 1.5 m further back and walks ahead at 0.3 m/s through 10 sweeps (2.7 m: "
                     "through the scene's objects, which the simulator lets it do); figures as in the scenes' table, "
                     "of each sweep's own map (every beam at the base's pose at its own time) and of the fused map "
                     "(fused walkable RMSE; beyond 2 sigma: of its walkable cells, the share whose error exceeds twice "
                     "the sigma it states).\n\n" +
                     table(["scene", "rig", "correct faces", "walkable RMSE [cm]", "fused walkable RMSE [cm]",
                            "step edges: median / p95 [cm]; unknown [%]", "invented [%]", "beyond 2 sigma [%]",
                            "steppable: precision / recall [%]"], rows))

    # ---- the split ----------------------------------------------------------
    def figure3(self):
        seeds = 5 if self.quick else 20
        out = run([self.tool("figure3"), "--seeds", str(seeds)])
        rows = [l.split(",") for l in out.splitlines()[1:] if l]
        self.section("The Figure 3 experiment: fixed against adaptive split threshold",
                     f"BIN/figure3 --seeds {seeds}",
                     "A 0.6 m board at 1 and 2 m before a background, a wall at 10, 20 and 30 m; the fixed threshold "
                     "(3 cm) against the adaptive one (zeta = 0.01), data-sheet noise, means a scan. Spurious: an "
                     "edge point farther than 2 beams from every true edge.\n\n" +
                     table(["distance [m]", "mode", "segments", "edge points", "spurious", "true edges found", "true"],
                           rows))

    # ---- speed --------------------------------------------------------------
    def speed(self):
        out = json.loads(run([self.tool("bench_split"), "--benchmark_format=json"]))
        split = {b["name"]: b["real_time"] * (1e-3 if b["time_unit"] == "ns" else 1.0) for b in out["benchmarks"]}
        out = run([self.tool("bench_sweep")])
        med = [l for l in out.splitlines() if "_median" in l and l.startswith("Sweep")]
        kv = dict(re.findall(r"(\w+(?:/\w+)?)=([0-9.]+)", med[0])) if med else {}
        rows = [[k, f"{v:.1f} us"] for k, v in split.items() if "/" in k]
        for key, what in (("split_ms", "split of a 1081 x 200 sweep"), ("group_ms", "grouping of that sweep, as lines arrive"),
                          ("latency_ms", "latency after its last line (finish, map, its uncertainty layer)"),
                          ("finish_ms", "of it: the grouping's finish"), ("map_ms", "of it: the height map"),
                          ("sigma_ms", "of it: the map's uncertainty layer"),
                          ("steppable_ms", "the steppable layer besides (built while subscribed)")):
            if key in kv:
                rows.append([what, f"{float(kv[key]):.2f} ms"])
        # Each layer alone on one finished sweep, the fastest of five repetitions.
        for name, what in (("HeightMap", "the height map alone, on one finished sweep (fastest of five runs)"),
                           ("Uncertainty", "its uncertainty layer alone (the same)"),
                           ("Steppable", "its steppable layer alone (the same)")):
            m = re.search(rf"^{name}/\S*_min\s+([0-9.]+) us", out, re.M)
            if m:
                rows.append([what, f"{float(m.group(1)) / 1e3:.2f} ms"])
        self.summary["latency"] = f"{float(kv.get('latency_ms', 'nan')):.2f} ms"
        # segment_cloud on a 500 x 500 range image
        tmp = tempfile.mkdtemp()
        img = os.path.join(tmp, "stairs500.pcd")
        run([self.tool("scene_cloud"), img, "--scene", "stairs", "--size", "500", "--seed", "1"])
        times = []
        for _ in range(3 if self.quick else 5):
            head = run([self.tool("segment_cloud"), img]).splitlines()[0]
            m = re.search(r"([0-9.]+) ms", head)
            times.append(float(m.group(1)))
        rows.append(["segment_cloud, a 500 x 500 range image of the stairs (median of runs)",
                     f"{statistics.median(times):.1f} ms"])
        shutil.rmtree(tmp, ignore_errors=True)
        self.section("Speed", "BIN/bench_split; BIN/bench_sweep; BIN/scene_cloud IMG.pcd --scene stairs --size 500; "
                     "BIN/segment_cloud IMG.pcd",
                     "CPU time on this machine (its speed varies from hour to hour: compare builds in one session). "
                     "bench_split: one 1081-beam scan; bench_sweep: medians of 20 sweeps in five runs, the median "
                     "run.\n\n" + table(["what", "time"], rows))

    def pipeline(self):
        if self.quick:
            return
        runs = []
        for _ in range(3):
            out = run(["bash", os.path.join(ROOT, "scripts", "bench", "bench_pipeline.sh"), "30", "10"],
                      env=dict(os.environ, TLP_WS=self.ws))
            m = re.search(r"cpu_percent=([0-9.]+) rss_mb=([0-9.]+)", out)
            if m:
                runs.append((float(m.group(1)), float(m.group(2))))
        if not runs:
            return
        cpu = statistics.median(r[0] for r in runs)
        rss = statistics.median(r[1] for r in runs)
        self.summary["cpu"] = f"{cpu:.1f} % of one core, {rss:.0f} MB"
        self.section("Cost of the running head", "bash scripts/bench/bench_pipeline.sh 30 10 (three runs)",
                     "sim.launch on the emulated head (stairs, 40 Hz scans of 1081 beams, the grouper on, nobody "
                     "subscribed to the outputs): the head's process (driver, splitter, grouper, tf) over 30 s after "
                     "10 s, not counting the emulator and ROS's own processes.\n\n" +
                     table(["run", "CPU [% of one core]", "resident [MB]"],
                           [[i + 1, f"{c:.2f}", f"{r:.1f}"] for i, (c, r) in enumerate(runs)] +
                           [["median", f"{cpu:.2f}", f"{rss:.1f}"]]))

    # ---- data nobody here made ----------------------------------------------
    def bag_rows(self, rows, bag, out_bag, args):
        """group_bag on an imported recording: a row per sweep (planes, floor and largest wall in one plane)."""
        out = run([self.tool("group_bag"), out_bag, "--urdf", out_bag[:-4] + ".urdf"] + args)
        planes = re.findall(r"sweep \d+: \d+ lines, (\d+) planes", out)
        for k, m in enumerate(re.finditer(r"room: floor at z=[-0-9.]+ m: \d+ points, ([0-9.]+) % in plane -?\d+; "
                                          r"(?:largest wall \(normal (\d+) deg, [-0-9.]+ m\): \d+ points, ([0-9.]+) %"
                                          r"|no vertical plane)", out)):
            wall = f"largest wall {m.group(3)} %" if m.group(3) else "no vertical plane"
            rows.append([f"{bag} sweep {k} (import_tilt_bag.py, group_bag {' '.join(args)})",
                         f"{planes[k] if k < len(planes) else '?'} planes; floor {m.group(1)} % in one plane, "
                         f"{wall} in one plane"])
        if "closed sweep" in out:
            rows[-1][1] += " (the recording's end closed this sweep)"

    def other_rigs(self):
        data = os.path.join(self.shared, "data")
        if not os.path.isdir(data):
            self.section("Data from elsewhere", "-", f"`{data}` is absent: not run.")
            return
        rows = []
        synpeb = os.path.join(data, "synpeb", "test_100.pcd")
        if os.path.exists(synpeb):
            for extra in ([], ["--noise", "off"]):
                out = run([self.tool("segment_cloud"), synpeb, "--truth-field", "intensity"] + extra)
                m = re.search(r"correct=(\d+) over=(\d+) under=(\d+) missed=(\d+) noise=(\d+)", out)
                t = re.search(r"(\d+) planes; at", out)
                rows.append([f"SynPEB test_100 (segment_cloud{' ' + ' '.join(extra) if extra else ''})",
                             f"{m.group(1)} of {t.group(1) if t else '?'} planes correct, noise {m.group(5)}"])
        tmp = tempfile.mkdtemp()
        for bag in ("room_240", "cardboard_box", "first_scan"):
            path = os.path.join(data, "real", "tilting_lidar_scanner", bag + ".bag")
            if not os.path.exists(path):
                continue
            out_bag = os.path.join(tmp, bag + "_tlp.bag")
            run([sys.executable, os.path.join(ROOT, "scripts", "import_tilt_bag.py"), path, out_bag])
            # room_240's stand stands on a table: the room's floor is at z = 0.10 m (../shared/data/README.md)
            floor = ["--floor-z", "0.10"] if bag == "room_240" else ["--room"]
            for order in ([], ["--reverse"]):
                self.bag_rows(rows, bag, out_bag, floor + order)
        shutil.rmtree(tmp, ignore_errors=True)
        dtk = os.path.join(data, "real", "3dtk", "scan000.3d")
        if os.path.exists(dtk):
            for more, label in (([], ""), (["--reverse"], ", lines reversed"), (["--line-sigma-deg", "0"], ", no line term")):
                out = run([self.tool("segment_cloud"), dtk, "--surface", "ceiling:-40,40,-40,40,1.85,2.15",
                           "--surface", "floor:-40,40,-40,40,-0.6,-0.3"] + more)
                sig = re.search(r"line pose error ([\d.]+) deg \((\w+)\)", out)
                parts = []
                for m in re.finditer(r"surface (\w+): \d+ points .*?largest plane ([\d.]+) % \(plane -?\d+\), in planes "
                                     r"([\d.]+) %, planes for 80 %: (\w+)", out):
                    parts.append(f"{m.group(1)}: largest plane {m.group(2)} %, in planes {m.group(3)} %, "
                                 f"planes for 80 %: {m.group(4)}")
                if not more:
                    self.summary["dtk"] = "; ".join(p.split(", in planes")[0] for p in parts)
                rows.append([f"3dtk scan000.3d (segment_cloud --surface{label})",
                             f"line pose error {sig.group(1)} deg ({sig.group(2)}); " + "; ".join(parts)])
        drc = os.path.join(data, "real", "drc", "tilted-steps.pcd")
        if os.path.exists(drc):
            for given in (False, True):
                out = run([self.tool("segment_cloud"), drc] + (DRC_GEOMETRY if given else []) + DRC_SURFACES)
                lines = re.search(r"(\d+) scan lines of up to", out)
                ms = float(re.search(r"points in planes; ([\d.]+) ms", out).group(1))
                est = re.search(r"spin axis estimated .*?: origin (\S+) axis (\S+);.*?; (\d+) ms", out)
                parts, tops = [], []
                for m in re.finditer(r"surface (\w+): \d+ points .*?largest plane ([\d.]+) % \(plane (-?\d+)\)", out):
                    parts.append(f"{m.group(1)} {m.group(2)} %")
                    if m.group(1) != "ground":
                        tops.append(m.group(3))
                shared = len(tops) - len(set(tops))
                how = (f"{ms:.1f} ms" if given else
                       f"origin {est.group(1)}, axis {est.group(2)} estimated; {float(est.group(3)) + ms:.0f} ms with the estimate")
                rows.append([f"{os.path.relpath(drc, data)} (segment_cloud"
                             + (" --origin --axis from its README)" if given else ", the file alone)"),
                             f"{lines.group(1) if lines else '?'} lines rebuilt, {how}; largest "
                             f"plane of each: " + ", ".join(parts) +
                             (f"; {shared} top(s) share a plane" if shared else "; no two tops share a plane")])
                if not given:
                    self.summary["drc"] = rows[-1][1]
        self.section("Data from elsewhere", "BIN/segment_cloud CLOUD --truth-field intensity [--noise off]; "
                     "python3 scripts/import_tilt_bag.py BAG OUT.bag && BIN/group_bag OUT.bag --urdf OUT.urdf --room "
                     "[--reverse] (room_240: --floor-z 0.10); BIN/segment_cloud scan000.3d --surface ceiling:-40,40,-40,40,1.85,2.15 "
                     "--surface floor:-40,40,-40,40,-0.6,-0.3 [--reverse] [--line-sigma-deg 0]; BIN/segment_cloud tilted-steps.pcd "
                     "[" + " ".join(DRC_GEOMETRY) + "] " + " ".join(DRC_SURFACES),
                     f"The recordings and clouds of `{os.path.relpath(data, ROOT)}` (its README says what each is). "
                     "`--room`: the share of the floor (the lowest level holding 2 % of the points, or the level "
                     "`--floor-z` names) and of the largest wall (the vertical surface most points of vertical planes "
                     "lie on; its points: all within 5 cm of it above the floor but a level plane's) that their "
                     "largest plane holds. `--surface`: the points in the box within 3 rms of "
                     "their plane, the share the largest plane holds, the share in any plane, and how many planes "
                     "hold 80 %.\n\n" + table(["data", "result"], rows))
        room = [r for r in rows if r[0].startswith("room_240 sweep 0")]
        if room:
            self.summary["room"] = room[0][1]

    def calibration(self):
        out = run([self.tool("bench_calibrate")])
        med = [l for l in out.splitlines() if "median" in l or (l.startswith("BM_") or l.startswith("Calib"))]
        m = re.search(r"^(\S+)\s+([0-9.]+) (ms|s|us)\s+([0-9.]+) (ms|s|us)", "\n".join(med), re.M)
        if m:
            self.section("Calibration's run time", "BIN/bench_calibrate",
                         f"The estimator on 10 sweeps of the stairs: {m.group(2)} {m.group(3)} ({m.group(1)}).")

    # ---- output ---------------------------------------------------------------
    def write(self, out_path, readme, seconds):
        commit = run(["git", "-C", ROOT, "rev-parse", "--short", "HEAD"]).strip()
        dirty = run(["git", "-C", ROOT, "status", "--porcelain", "--untracked-files=no"]).strip()
        cpu = "unknown"
        try:
            with open("/proc/cpuinfo") as f:
                cpu = next(l.split(":", 1)[1].strip() for l in f if l.startswith("model name"))
        except (OSError, StopIteration):
            pass
        mem = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") / 2**30
        now = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
        lines = ["# Evaluation report", "",
                 "Generated by `bash scripts/report.sh` (do not edit: run it again). BIN is "
                 "`build_ws/install/tilt_laser_perception/lib/tilt_laser_perception`.", "",
                 f"- date: {now}",
                 f"- commit: {commit}{' with uncommitted changes' if dirty else ''}",
                 f"- machine: {cpu}, {os.cpu_count()} cores, {mem:.0f} GiB, {platform.platform()}",
                 f"- the report's run took {seconds / 60:.1f} minutes" + (" (--quick)" if self.quick else ""), "",
                 "## What to expect", "", self.summary_table(), ""]
        for title, command, text in self.sections:
            lines += [f"## {title}", "", f"Command: `{command}`", "", text, ""]
        with open(out_path, "w") as f:
            f.write("\n".join(lines))
        if readme:
            with open(readme) as f:
                text = f.read()
            a, b = text.find(BEGIN), text.find(END)
            if a < 0 or b < 0:
                sys.exit(f"{readme} has no report:summary markers")
            # No date and no commit here: those are the report's (README says what to expect, not when).
            block = (BEGIN + "\n" + self.summary_table() + f"\n\nOn {os.cpu_count()} cores of an {cpu}; "
                     "every figure with its command in [doc/evaluation.md](doc/evaluation.md).\n")
            with open(readme, "w") as f:
                f.write(text[:a] + block + text[b:])

    def summary_table(self):
        s = self.summary
        rows = [["sweep period (10-60 degrees at 1 rad/s)", s.get("period", "not measured")],
                ["latency: the sweep's last scan to its planes and map (bench_sweep)", s.get("latency", "not measured")],
                ["CPU and memory of the running head (driver, splitter, grouper, tf)", s.get("cpu", "not measured")],
                ["stairs scene (simulated), per sweep", s.get("stairs", "not measured")],
                ["clutter scene (simulated), per sweep", s.get("clutter", "not measured")],
                ["walking towards the stairs", s.get("walk", "not measured")],
                ["a spinning head (simulated, evaluate --spin 1.0)", s.get("spin", "not measured")],
                ["a real tilting stand (room_240, its first sweep)", s.get("room", "not measured")],
                ["a real nodding SICK scan (3DTK scan000)", s.get("dtk", "not measured")],
                ["a real spinning UTM-30LX's flat cloud (DRC tilted-steps, segment_cloud given the file alone)",
                 s.get("drc", "not measured")]]
        return table(["what", "figure"], rows)


# tilted-steps.pcd: the sensor and the spin axis, and boxes a little inside each block top and over the ground
# (../shared/data/README.md).
DRC_GEOMETRY = ["--origin", "0.248091,0.012443,1.806473", "--axis", "0.837001,0.019831,-0.546842"]
DRC_SURFACES = ["--surface", "A:0.57,0.91,-0.12,0.13,0.12,0.22", "--surface", "B:0.97,1.30,-0.12,0.13,0.28,0.36",
            "--surface", "C1:0.57,0.91,-0.58,-0.28,0.13,0.21", "--surface", "C2:0.99,1.32,-0.58,-0.28,0.10,0.16",
            "--surface", "D:1.39,1.72,-0.58,-0.28,0.11,0.22", "--surface", "ground:-10,10,-10,10,-0.07,0.03"]

STEPS = ("scenes", "spinning", "density", "walking", "walking_scenes", "figure3", "speed", "calibration", "other_rigs", "pipeline")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--ws", default=os.path.join(ROOT, "build_ws"))
    ap.add_argument("--shared", default=os.path.join(ROOT, "..", "shared"))
    ap.add_argument("--out", default=os.path.join(ROOT, "doc", "evaluation.md"))
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--no-readme", action="store_true")
    ap.add_argument("--only", choices=STEPS, help="run this section alone and print it; write nothing")
    ap.add_argument("--bin", help="the tools' directory (default: the workspace's); with --only, to compare builds")
    a = ap.parse_args()
    bin_dir = a.bin or os.path.join(a.ws, "install", "tilt_laser_perception", "lib", "tilt_laser_perception")
    if not os.path.exists(os.path.join(bin_dir, "evaluate")):
        sys.exit(f"no build in {a.ws}: run scripts/build.sh (or scripts/report.sh)")
    t0 = time.time()
    r = Report(bin_dir, os.path.abspath(a.ws), os.path.abspath(a.shared), a.quick)
    if a.only:
        getattr(r, a.only)()
        r.cleanup()
        for title, command, text in r.sections:
            print(f"## {title}\n\n`{command}`\n\n{text}\n")
        return
    for step in STEPS:
        getattr(r, step)()
    r.cleanup()
    r.write(a.out, None if a.no_readme else os.path.join(ROOT, "README.md"), time.time() - t0)
    print(f"wrote {a.out} in {(time.time() - t0) / 60:.1f} minutes")


if __name__ == "__main__":
    main()
