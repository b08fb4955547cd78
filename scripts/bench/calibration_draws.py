#!/usr/bin/env python3
"""The calibration against known errors: for N random draws of a joint offset
(+-2 deg), a time offset (+-10 ms) and a mount roll and yaw (+-1 deg), a
recording made by make_scene_bag with those errors (alone, and with the
simulator's other rig errors: --realistic's encoder noise and quantization,
line jitter, beam footprint, and gear play unless --backlash-deg says
otherwise), calibrate on it, and evaluate on the same scene with the estimate
applied against evaluate with the errors known exactly.

  calibration_draws.py BIN_DIR [--draws 10] [--seed 1] [--scene stairs] [--duration 7] [--backlash-deg 0]

Prints one line per draw and variant (the errors, the estimate's errors, the
normal error and height map RMSE of both evaluations) and a summary: the
largest estimate error of each parameter and how many draws are within
0.05 deg / 0.5 ms, and within 10 % of the errors-known evaluation.
A gear play b at tilt speed w looks like a time offset of b / (2 w) (it
cannot be told apart at one speed): with --backlash-deg B the time offset is
judged against the truth plus that lag, and the line says so.
"""
import argparse
import math
import os
import random
import subprocess
import sys
import tempfile


def fields(line):
    out = {}
    for tok in line.split():
        if "=" in tok:
            k, v = tok.split("=", 1)
            try:
                out[k] = float(v)
            except ValueError:
                out[k] = v
    return out


def run(cmd):
    r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    if r.returncode != 0:
        sys.exit("failed: %s\n%s" % (" ".join(cmd), r.stderr))
    return r.stdout


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("bin")
    ap.add_argument("--draws", type=int, default=10)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--scene", default="stairs")
    ap.add_argument("--duration", type=float, default=7.0)
    ap.add_argument("--sweeps", type=int, default=6, help="evaluate's sweeps")
    ap.add_argument("--backlash-deg", type=float, default=0.0, help="gear play in the 'other errors' variant")
    ap.add_argument("--speed", type=float, default=1.0)
    a = ap.parse_args()
    rng = random.Random(a.seed)
    tmp = tempfile.mkdtemp(prefix="tlp_cal_")
    worst = {}
    within = {"alone": 0, "other errors": 0}
    eval_within = {"alone": 0, "other errors": 0}
    for d in range(a.draws):
        j, t = rng.uniform(-2, 2), rng.uniform(-10, 10)
        r, y = rng.uniform(-1, 1), rng.uniform(-1, 1)
        errors = ["--joint-offset-deg", "%.4f" % j, "--time-offset-ms", "%.3f" % t, "--mount-error-deg", "%.4f,%.4f" % (r, y)]
        for variant in ("alone", "other errors"):
            rig = errors if variant == "alone" else ["--realistic", "--backlash-deg", str(a.backlash_deg)] + errors
            bag = os.path.join(tmp, "d%d.bag" % d)
            yaml = os.path.join(tmp, "d%d.yaml" % d)
            seed = str(100 + d)
            run([os.path.join(a.bin, "make_scene_bag"), "--scene", a.scene, "--out", bag, "--duration", str(a.duration),
                 "--seed", seed, "--speed", str(a.speed)] + rig)
            out = run([os.path.join(a.bin, "calibrate"), bag, "--out", yaml])
            est = fields(out.splitlines()[0])
            lag = a.backlash_deg / 2.0 / math.degrees(a.speed) * 1e3 if variant != "alone" else 0.0
            err = {
                "joint_offset_deg": est["joint_offset_deg"] - j,
                "time_offset_ms": est["time_offset_ms"] - (t + lag),
                "mount_roll_deg": est["mount_roll_deg"] - r,
                "mount_yaw_deg": est["mount_yaw_deg"] - y,
            }
            ok = all(abs(v) <= (0.5 if k == "time_offset_ms" else 0.05) for k, v in err.items())
            within[variant] += ok
            for k, v in err.items():
                worst[(variant, k)] = max(worst.get((variant, k), 0.0), abs(v))
            ev = [os.path.join(a.bin, "evaluate"), "--scene", a.scene, "--sweeps", str(a.sweeps), "--seed", seed] + rig
            cal = fields(run(ev + ["--calibration", yaml]).splitlines()[-1])
            known = fields(run(ev + ["--errors-known"]).splitlines()[-1])
            eok = (cal["normal_err_deg"] <= 1.1 * known["normal_err_deg"] and
                   cal["heightmap_rmse_m"] <= 1.1 * known["heightmap_rmse_m"])
            eval_within[variant] += eok
            print("draw %d %-12s truth %+.3f deg %+.2f ms %+.3f %+.3f deg | estimate off by %+.4f deg %+.3f ms%s "
                  "%+.4f %+.4f deg %s | normal %.3f (known %.3f) deg, height map %.4f (known %.4f) m %s | rms %.4f -> %.4f m"
                  % (d, variant, j, t, r, y, err["joint_offset_deg"], err["time_offset_ms"],
                     " (of truth + gear lag %.2f ms)" % lag if lag else "", err["mount_roll_deg"], err["mount_yaw_deg"],
                     "ok" if ok else "OFF", cal["normal_err_deg"], known["normal_err_deg"], cal["heightmap_rmse_m"],
                     known["heightmap_rmse_m"], "ok" if eok else "WORSE", est["plane_rms_before_m"],
                     est["plane_rms_after_m"]), flush=True)
    for variant in ("alone", "other errors"):
        print("%s: %d of %d draws within 0.05 deg / 0.5 ms, %d within 10 %% of the errors-known evaluation; largest "
              "errors: %s" % (variant, within[variant], a.draws, eval_within[variant],
                              " ".join("%s %.4f" % (k, worst[(variant, k)]) for k in
                                       ("joint_offset_deg", "time_offset_ms", "mount_roll_deg", "mount_yaw_deg"))))


if __name__ == "__main__":
    main()
