#!/usr/bin/env python3
"""How much a twin moves when its records move by far less than their own noise.

    .venv/bin/python bench/twin_stability.py DATA_DIR OUT_DIR [--draws N] [--eps E]

DATA_DIR is in the form `bench/campaign_vs_truth.py` reads (`campaign/*.csv` time series,
`truth/*_loaded.csv` analytic receptance). Each draw adds to every response column white
noise of E (default 0.01) times that column's own noise level (the RMS of the quietest
tenth of its 64-sample blocks), writes the records again and runs
`bench/campaign_vs_truth.py` on them: defaults only, twin vs truth per pose and channel,
30-2500 Hz. A sound identification moves by about what the data move (hundredths of a
point); a spread of points means a discrete choice (order, weighting, separation of
ringing hits) that the data cannot make. Prints each draw's fits and the spread.
"""
import argparse
import glob
import os
import re
import shutil
import subprocess
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))


def perturb(src, dst, eps, rng):
    lines = open(src).read().splitlines()
    head = [line for line in lines if line.startswith("#")]
    body = [line for line in lines if not line.startswith("#")]
    names = body[0].split(",")
    data = np.array([[float(v) for v in row.split(",")] for row in body[1:]])
    for j, name in enumerate(names):
        # response columns: accelerations, velocities or displacements (not t, force, pose)
        if re.fullmatch(r"[avd][xyz]", name):
            # the column's noise: the quietest tenth of its 64-sample blocks (RMS)
            blocks = data[: len(data) // 64 * 64, j].reshape(-1, 64)
            level = np.percentile(np.sqrt((blocks ** 2).mean(axis=1)), 10)
            data[:, j] += eps * level * rng.normal(size=len(data))
    with open(dst, "w") as fh:
        fh.write("\n".join(head + [body[0]]) + "\n")
        for row in data:
            fh.write(",".join(repr(float(v)) for v in row) + "\n")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("data")
    ap.add_argument("out")
    ap.add_argument("--draws", type=int, default=4)
    ap.add_argument("--eps", type=float, default=0.01)
    a = ap.parse_args()
    fits = {}
    for k in range(a.draws + 1):
        d = os.path.join(a.out, f"draw{k}")
        os.makedirs(os.path.join(d, "campaign"), exist_ok=True)
        if not os.path.exists(os.path.join(d, "truth")):
            shutil.copytree(os.path.join(a.data, "truth"), os.path.join(d, "truth"))
        rng = np.random.default_rng(k)
        for src in sorted(glob.glob(os.path.join(a.data, "campaign", "*.csv"))):
            dst = os.path.join(d, "campaign", os.path.basename(src))
            if k == 0:
                shutil.copy(src, dst)
            else:
                perturb(src, dst, a.eps, rng)
        o = subprocess.run([sys.executable, os.path.join(HERE, "campaign_vs_truth.py"), d,
                            os.path.join(d, "result")], capture_output=True, text=True)
        if o.returncode:
            sys.exit(o.stderr)
        for line in o.stdout.splitlines():
            m = re.match(r"^(\S+)\s+(.*)$", line)
            if not m or "poses" in line:
                continue
            for ch, v in re.findall(r"(\w\w) twin\s+([-\d.]+) %", m.group(2)):
                fits.setdefault((m.group(1), ch), []).append(float(v))
        print(f"draw {k} ({'as recorded' if k == 0 else f'+{a.eps:g} of the noise'}) done",
              flush=True)
    print("\n| pose | channel | as recorded | perturbed draws | spread |")
    print("|---|---|---:|---|---:|")
    for (pose, ch), v in sorted(fits.items()):
        rest = " ".join(f"{x:.2f}" for x in v[1:])
        print(f"| {pose} | {ch} | {v[0]:.2f} | {rest} | {max(v) - min(v):.2f} |")


if __name__ == "__main__":
    main()
