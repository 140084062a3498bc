#!/usr/bin/env python3
"""A campaign's twin against the analytic truth of a data set in the tryout form.

    python bench/campaign_vs_truth.py DATA_DIR OUT_DIR [--lo HZ] [--hi HZ] [--split HZ]

DATA_DIR holds `campaign/*.csv` (impact records per pose, `gNN_x.csv`, `gNN_y.csv`) and
`truth/*_loaded.csv` (analytic receptance with the sensor's mass, the pose in its first
comment line; `truth/*.csv` where no loaded truth is given), as `../shared/data/tryout_gantry` and the second generator's dumps
(`cargo run --release -p lumped --example dump -- --out DIR --seed N`) do. The twin is
identified with default options only (`mtwin identify FILES --out OUT_DIR/twin.json`,
reused when present), evaluated with `mtwin eval` at every pose of the truth, and its xx
and yy receptance (`--channels` for others) compared with the truth between --lo and --hi (30-2500 Hz) by the fit
percentage `100 (1 - |t - e| / |t - mean t|)`; at measured poses also mtwin's own H1 of
that pose's records (`mtwin frf`) against the same truth. `--split HZ` adds the summary
below and above HZ (each part scored on its own lines). Needs numpy (the project's
.venv has it).
"""
import argparse
import csv
import glob
import json
import os
import re
import subprocess
import sys

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
MTWIN = os.environ.get("MTWIN", os.path.join(ROOT, "target", "release", "mtwin"))


def fit_pct(t, e):
    return 100.0 * (1.0 - np.linalg.norm(t - e) / np.linalg.norm(t - t.mean()))


def read(path):
    pose, rows = None, []
    with open(path) as fh:
        for line in fh:
            if line.startswith("#"):
                m = re.search(r"pose=([-\d.]+),([-\d.]+),([-\d.]+)", line)
                if m:
                    pose = [float(x) for x in m.groups()]
                continue
            rows.append(line.strip())
    return pose, list(csv.DictReader(rows))


def channel(rows, c):
    return np.array([complex(float(r[c + "_re"]), float(r[c + "_im"])) for r in rows])


def on(f_to, f_from, h):
    return np.interp(f_to, f_from, h.real) + 1j * np.interp(f_to, f_from, h.imag)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("data")
    ap.add_argument("out")
    ap.add_argument("--lo", type=float, default=30.0)
    ap.add_argument("--hi", type=float, default=2500.0)
    ap.add_argument("--split", type=float, default=None,
                    help="also summarise the fits below and above this frequency [Hz] "
                         "(where the twin's error lies: e.g. the band edge)")
    ap.add_argument("--channels", default="xx,yy",
                    help="channels compared, comma-separated (xx,yy; cross channels xy,yx)")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    twin = os.path.join(a.out, "twin.json")
    if not os.path.exists(twin):
        files = sorted(glob.glob(os.path.join(a.data, "campaign", "*.csv")))
        r = subprocess.run([MTWIN, "identify", "-q"] + files + ["--out", twin],
                           capture_output=True, text=True)
        if r.returncode:
            sys.exit(r.stderr)
    summary = {}
    # with the sensor's mass where the data set gives it (what impact data can show)
    truths = sorted(glob.glob(os.path.join(a.data, "truth", "*_loaded.csv")))
    if not truths:
        truths = [p for p in sorted(glob.glob(os.path.join(a.data, "truth", "*.csv")))
                  if not os.path.basename(p).startswith("centre")]
    for tp in truths:
        name = os.path.basename(tp).replace("_loaded", "")[: -len(".csv")]
        if name.startswith("centre"):
            continue
        pose, truth = read(tp)
        f = np.array([float(r["f_hz"]) for r in truth])
        sel = (f >= a.lo) & (f <= a.hi)
        ev = os.path.join(a.out, f"eval_{name}.csv")
        grid = os.path.join(a.out, f"freqs_{name}.txt")
        with open(grid, "w") as fh:
            fh.write("\n".join(repr(float(x)) for x in f[sel]) + "\n")
        # the twin at the truth's own lines (no interpolation across a resonance)
        subprocess.run([MTWIN, "eval", "-q", "--twin", twin, "--at", ",".join(map(str, pose)),
                        "--freqs", grid, "--out", ev], check=True)
        _, model = read(ev)
        records = sorted(glob.glob(os.path.join(a.data, "campaign", f"{name}_*.csv")))
        h1 = None
        if records:
            hp = os.path.join(a.out, f"h1_{name}.csv")
            sp = os.path.join(a.out, f"h1_{name}.sigma")
            if not os.path.exists(hp) or not os.path.exists(sp):
                o = subprocess.run([MTWIN, "frf", "--json"] + records + ["--out", hp],
                                   check=True, capture_output=True, text=True)
                with open(sp, "w") as fh:
                    fh.write(str(json.loads(o.stdout).get("exp_window_sigma") or 0.0))
            _, h1 = read(hp)
            # an exponential window makes the estimate H(s + sigma), not H(s): no fair
            # reference for the truth, and said so
            sigma = float(open(sp).read())
        line = [f"{name:4}"]
        for c in a.channels.split(","):
            t = channel(truth, c)
            ts, e = t[sel], channel(model, c)
            twin_fit = fit_pct(ts, e)
            summary.setdefault((name[0], c), []).append(twin_fit)
            if a.split is not None:
                fs = f[sel]
                for part, m in (("below", fs < a.split), ("above", fs >= a.split)):
                    if m.sum() > 2:
                        summary.setdefault((name[0], c, part), []).append(fit_pct(ts[m], e[m]))
            text = f"{c} twin {twin_fit:7.2f} %"
            if h1 is not None:
                fh = np.array([float(r["f_hz"]) for r in h1])
                hs = (fh >= a.lo) & (fh <= a.hi)
                text += f" (own H1 {fit_pct(on(fh[hs], f, t), channel(h1, c)[hs]):7.2f} %"
                text += f", windowed: H(s + {sigma:.1f}/s))" if sigma > 0 else ")"
            line.append(text)
        print("  ".join(line))
    part_order = {"below": 1, "above": 2}
    for key, v in sorted(summary.items(),
                         key=lambda kv: (kv[0][0], kv[0][1], part_order.get(kv[0][-1], 0))):
        kind, c = key[0], key[1]
        what = "measured" if kind == "g" else "unmeasured"
        span = f"{a.lo:g}-{a.hi:g} Hz"
        if len(key) == 3:
            span = f"{a.lo:g}-{a.split:g} Hz" if key[2] == "below" else f"{a.split:g}-{a.hi:g} Hz"
        print(f"{what} poses {c}: mean {np.mean(v):.2f} %, worst {np.min(v):.2f} % "
              f"({span}, {len(v)} poses)")


if __name__ == "__main__":
    main()
