#!/usr/bin/env python3
"""Hidden-effect cases made from the independent tryout generator's analytic truth, many
seeds, diagnosed with defaults only; prints a table per row.

    .venv/bin/python bench/tryout_truth_cases.py [SEEDS] [--one-pose] [--keep=DIR] [-v]

Needs numpy (the project's venv has it: `scripts/setup-python.sh`). The machine is
`../shared/data/tryout_gantry/truth/machine.json` (seven modes: frequency, damping, modal
stiffness, direction); every response is the exact convolution (FFT, zero-padded) of the
forces with its receptance times -w^2, with the tryout files' sensor noise (force 0.08 N,
acceleration 0.029 m/s^2 RMS), at 10240 Hz. The forms follow the tryout files and the
command-line tests of `tests/cli/tryout_hidden.rs` (other random draws):

- impact (x and y hammer, five ~300 N hits 0.4 s apart, each +-10 ms): `healthy`, a pure
  x/y mode turned 15-30 degrees (`cross_coupling`), a new x or y mode at 300-1500 Hz
  (`unmodeled_mode`), a stiffness loss of 10-25 % (`mode_change`, new frequency within
  1 %), damping x1.6-2.2 (`mode_change`), responses 2-6 samples late (`time_delay`);
- three force levels (~100 / 400 / 1000 N, three hits each, +-10 ms; 3.6 s): the linear
  machine hammered along x and along y (`none`), and one pure x/y mode with a cubic spring
  raising it 1.5-3 % at the heaviest hits (`nonlinearity`, hardening; that mode integrated
  by Runge-Kutta, 16 steps per sample);
- milling (down-milling, 3 teeth, two speeds in 5000-9000 rpm, 3 s each, tooth-to-tooth
  runout 8 %), with tooth and spindle harmonics only (`periodic`) and with a broadband
  share of half the force's RMS (`broadband`): healthy, an outside vibration at two
  frequencies in 30-400 Hz off the tooth harmonics (`disturbance`, both within 1 %), and a
  stiffness loss of 10-25 % (`mode_change`).

The twin: the one the defaults identify from `tryout_gantry/campaign/`, or with
`--one-pose` from the first seed's healthy impact test at the centre. A case is right when
the cause, its numbers (frequencies within 1 %, the nonlinear mode within 2 %, delay within
10 %, axis and kind where given) and a held-out gain > 1 point (cause not `none`) are. `-v`
prints every miss, and for every stiffness loss in milling how much it changes the
noise-free cuts (RMS of the x/y difference, relative and against the sensor noise).
"""
import json
import os
import subprocess
import sys
import tempfile
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
TARGET = os.environ.get("CARGO_TARGET_DIR") or os.path.join(ROOT, "target")
MTWIN = os.path.join(TARGET, "release", "mtwin")
TRYOUT = os.path.join(ROOT, "..", "shared", "data", "tryout_gantry")
FS = 10240.0
BASE = json.load(open(os.path.join(TRYOUT, "truth", "machine.json")))["modes"]
PURE = [i for i, m in enumerate(BASE) if max(abs(m["d"][0]), abs(m["d"][1])) > 0.99]
POSE = "0.6,0.4,0.15"
NOISE_ACC = 0.029  # accelerometer noise [m/s^2 RMS], as the tryout files


def responses(modes, force, delay=0.0):
    """Accelerations of `modes` under `force` (3 x n), `delay` samples late."""
    n = force.shape[1]
    npad = 2 * n
    F = np.fft.rfft(force, npad)
    f = np.fft.rfftfreq(npad, 1 / FS)
    w = 2 * np.pi * f
    acc = np.zeros((3, n))
    for o in range(3):
        Y = np.zeros_like(F[0])
        for i in range(3):
            H = np.zeros(len(f), complex)
            for m in modes:
                r = f / m["f0"]
                H += m["d"][o] * m["d"][i] / (m["k"] * (1 - r * r + 2j * m["zeta"] * r))
            Y += F[i] * H
        acc[o] = np.fft.irfft(Y * (-w * w) * np.exp(-1j * w * delay / FS), npad)[:n]
    return acc


def noisy(force, acc, rng):
    return np.vstack([force + rng.normal(0, 0.08, force.shape),
                      acc + rng.normal(0, NOISE_ACC, acc.shape)])


def write(path, what, cols):
    x = ",".join(["%.6e"] * 6)
    with open(path, "w") as fh:
        fh.write(f"# {what}\nt,fx,fy,fz,ax,ay,az,x,y,z\n")
        for i in range(cols.shape[1]):
            fh.write("%.7e," % (i / FS) + x % tuple(cols[:, i]) + f",{POSE}\n")


def hits(rng, n, axis, amps, t0):
    force = np.zeros((3, n))
    for h, amp in enumerate(amps):
        start = int((t0 + h * 0.4 + rng.uniform(-0.01, 0.01)) * FS)
        width = int(rng.integers(4, 6))
        j = np.arange(width)
        force[axis, start:start + width] += amp * np.sin(np.pi * (j + 0.5) / width)
    return force


def impact(modes, axis, delay, rng):
    force = hits(rng, 20480, axis, rng.uniform(270, 350, 5), 0.05 + rng.uniform(0, 0.02))
    return noisy(force, responses(modes, force, delay), rng)


def impact_levels(modes, axis, cubic, rng):
    """Three force levels; `cubic` = (mode index, shift at the heaviest hits) or None."""
    n = 36864
    amps = [lv * rng.uniform(0.85, 1.15) for lv in (100, 100, 100, 400, 400, 400,
                                                       1000, 1000, 1000)]
    force = hits(rng, n, axis, amps, 0.06)
    lin = [m for i, m in enumerate(modes) if cubic is None or i != cubic[0]]
    acc = responses(lin, force)
    if cubic is not None:
        m = modes[cubic[0]]
        wn = 2 * np.pi * m["f0"]
        mass = m["k"] / wn ** 2
        c = 2 * m["zeta"] * wn * mass
        amp = 1000 * 4 / FS * 2 / np.pi / (mass * wn)
        k3 = ((1 + cubic[1]) ** 2 - 1) * m["k"] * 4 / 3 / amp ** 2
        p = np.array(m["d"]) @ force
        sub, h = 16, 1 / (FS * 16)
        q = qd = 0.0
        qdd = np.zeros(n)

        def a(q, qd, f):
            return (f - c * qd - m["k"] * q - k3 * q ** 3) / mass
        for i in range(n):
            f0, f1 = p[i], p[min(i + 1, n - 1)]
            qdd[i] = a(q, qd, f0)
            for j in range(sub):
                fa, fb, fc = (f0 + (f1 - f0) * (j + x) / sub for x in (0.0, 0.5, 1.0))
                k1 = (qd, a(q, qd, fa))
                k2 = (qd + h / 2 * k1[1], a(q + h / 2 * k1[0], qd + h / 2 * k1[1], fb))
                k3_ = (qd + h / 2 * k2[1], a(q + h / 2 * k2[0], qd + h / 2 * k2[1], fb))
                k4 = (qd + h * k3_[1], a(q + h * k3_[0], qd + h * k3_[1], fc))
                q += h / 6 * (k1[0] + 2 * k2[0] + 2 * k3_[0] + k4[0])
                qd += h / 6 * (k1[1] + 2 * k2[1] + 2 * k3_[1] + k4[1])
        acc += np.outer(m["d"], qdd)
    return noisy(force, acc, rng)


def milling(modes, rpm, dist, broadband, rng, change=None):
    """Columns of one cut; with `change` (a list), appends to it how much `modes` change
    the noise-free response from the healthy machine's: the RMS of the x/y difference,
    means removed, relative to the healthy response's and to the sensor noise."""
    n = 3 * 10240
    t = np.arange(n) / FS
    teeth, kta = 3, 200.0
    runout = 1 + rng.uniform(-0.08, 0.08, teeth)
    phi_st = np.pi - np.arccos(1 - 2 / 3)
    force = np.zeros((3, n))
    rot = 2 * np.pi * rpm / 60 * t
    for j in range(teeth):
        phi = np.mod(rot + 2 * np.pi * j / teeth, 2 * np.pi)
        ft = kta * runout[j] * np.sin(phi) * ((phi >= phi_st) & (phi <= np.pi))
        fr = 0.3 * ft
        force[0] += -ft * np.cos(phi) - fr * np.sin(phi)
        force[1] += ft * np.sin(phi) - fr * np.cos(phi)
        force[2] += 0.2 * ft
    for c in range(3):
        force[c] += broadband * np.sqrt(np.mean(force[c] ** 2)) * rng.normal(0, 1, n)
    acc = responses(modes, force)
    if change is not None:
        ref = responses(BASE, force)[:2]
        ref -= ref.mean(axis=1, keepdims=True)
        d = acc[:2] - acc[:2].mean(axis=1, keepdims=True) - ref
        change.append((float(np.sqrt(np.sum(d ** 2) / np.sum(ref ** 2))),
                       float(np.sqrt(np.mean(d ** 2))) / NOISE_ACC))
    for f, rel in dist:
        for o in range(2):
            amp = rel * np.sqrt(np.mean(acc[o] ** 2)) * np.sqrt(2)
            acc[o] += amp * np.sin(2 * np.pi * f * t + rng.uniform(0, 2 * np.pi))
    return noisy(force, acc, rng)


def with_mode(i, **kw):
    m = [dict(x) for x in BASE]
    m[i].update(kw)
    return m


def impact_cases(rng):
    """(row, modes, delay, answer) of one seed."""
    out = [("healthy", BASE, 0, {"cause": "none"})]
    i = PURE[rng.integers(len(PURE))]
    ang = np.radians(rng.uniform(15, 30)) * rng.choice([-1, 1])
    d = BASE[i]["d"]
    turned = [d[0] * np.cos(ang) - d[1] * np.sin(ang), d[0] * np.sin(ang) + d[1] * np.cos(ang), 0]
    out.append(("cross_coupling", with_mode(i, d=turned), 0,
                {"cause": "cross_coupling", "freq_hz": BASE[i]["f0"]}))
    while True:
        fn = rng.uniform(300, 1500)
        if all(abs(fn / m["f0"] - 1) > 0.1 for m in BASE):
            break
    ax = int(rng.integers(2))
    new = {"f0": fn, "zeta": rng.uniform(0.015, 0.04), "k": rng.uniform(0.5e8, 1.5e8),
           "d": [float(ax == 0), float(ax == 1), 0.0]}
    out.append(("unmodeled_mode", [dict(x) for x in BASE] + [new], 0,
                {"cause": "unmodeled_mode", "freq_hz": fn, "axis": "xy"[ax]}))
    i = PURE[rng.integers(len(PURE))]
    sf = rng.uniform(0.75, 0.9)
    out.append(("stiffness_loss", with_mode(i, k=BASE[i]["k"] * sf, f0=BASE[i]["f0"] * sf ** 0.5),
                0, {"cause": "mode_change", "freq_hz": BASE[i]["f0"],
                    "new_freq_hz": BASE[i]["f0"] * sf ** 0.5}))
    i = PURE[rng.integers(len(PURE))]
    out.append(("damping_up", with_mode(i, zeta=BASE[i]["zeta"] * rng.uniform(1.6, 2.2)), 0,
                {"cause": "mode_change", "freq_hz": BASE[i]["f0"]}))
    k = int(rng.integers(2, 7))
    out.append(("time_delay", BASE, k, {"cause": "time_delay", "delay_s": k / FS}))
    return out


def right(want, d):
    det, cause = d.get("details", {}), d.get("cause")

    def within(a, b, r):
        return a is not None and b is not None and abs(a / b - 1) <= r
    wc = want["cause"]
    if wc == "none":
        num = True
    elif wc == "time_delay":
        num = within(det.get("delay_s"), want["delay_s"], 0.1)
    elif wc == "disturbance":
        found = det.get("freq_hz") or []
        found = found if isinstance(found, list) else [found]
        num = all(any(abs(f / t - 1) <= 0.01 for f in found) for t in want["freq_hz"])
    else:
        tol = 0.02 if wc == "nonlinearity" else 0.01
        num = (within(det.get("freq_hz"), want["freq_hz"], tol)
               and ("new_freq_hz" not in want or within(det.get("new_freq_hz"),
                                                        want["new_freq_hz"], 0.01))
               and ("axis" not in want or det.get("axis") == want["axis"])
               and ("kind" not in want or det.get("kind") == want["kind"]))
    gain = (d.get("fit_after_pct") or 0) - (d.get("fit_before_pct") or 0)
    return cause == wc and num and (wc == "none" or gain > 1), gain


def diagnose(twin, folder, want, tag, verbose, table, row, note=""):
    out = folder + "_out"
    o = subprocess.run([MTWIN, "diagnose", "-q", "--twin", twin, folder, "--out", out],
                       capture_output=True, text=True)
    if o.returncode:
        sys.exit(f"{tag}: {o.stderr}")
    d = json.load(open(os.path.join(out, "diagnosis.json")))
    ok, gain = right(want, d)
    t = table.setdefault(row, [0, 0, {}])
    t[0] += ok
    t[1] += 1
    t[2][d["cause"]] = t[2].get(d["cause"], 0) + 1
    if verbose and not ok:
        det = {k: v for k, v in d.get("details", {}).items()
               if k in ("freq_hz", "new_freq_hz", "axis", "kind", "delay_s")}
        print(f"{tag} {row}: found {d['cause']} {json.dumps(det)} gain {gain:.1f}, "
              f"want {json.dumps(want)}{note}", file=sys.stderr, flush=True)
    return ok


def main():
    args = [a for a in sys.argv[1:] if not a.startswith("-")]
    seeds = int(args[0]) if args else 4
    verbose = "-v" in sys.argv
    one_pose = "--one-pose" in sys.argv
    keep = next((a.split("=", 1)[1] for a in sys.argv if a.startswith("--keep=")), None)
    b = subprocess.run(["cargo", "build", "--release", "-q", "--bin", "mtwin"], cwd=ROOT)
    if b.returncode:
        sys.exit("cargo build failed")
    t0 = time.time()
    table = {}
    with tempfile.TemporaryDirectory() as tmp:
        base = keep or tmp
        os.makedirs(base, exist_ok=True)
        twin = os.path.join(base, "twin.json")
        if one_pose:
            rng = np.random.default_rng(1)
            centre = os.path.join(base, "centre")
            os.makedirs(centre, exist_ok=True)
            for axis in range(2):
                write(os.path.join(centre, f"imp_{'xy'[axis]}.csv"),
                      f"impact test, hammer along {'xy'[axis]}", impact(BASE, axis, 0, rng))
            src = [os.path.join(centre, f) for f in sorted(os.listdir(centre))]
        else:
            src = [os.path.join(TRYOUT, "campaign")]
        o = subprocess.run([MTWIN, "identify", "-q"] + src + ["--out", twin],
                           capture_output=True, text=True)
        if o.returncode:
            sys.exit(o.stderr)
        for seed in range(1, seeds + 1):
            rng = np.random.default_rng(1000 + seed)
            tag = f"seed {seed}"
            for row, modes, delay, want in impact_cases(rng):
                folder = os.path.join(base, f"s{seed}_{row}")
                os.makedirs(folder, exist_ok=True)
                for axis in range(2):
                    write(os.path.join(folder, f"imp_{'xy'[axis]}.csv"),
                          f"impact test, hammer along {'xy'[axis]}",
                          impact(modes, axis, delay, rng))
                diagnose(twin, folder, want, tag, verbose, table, row)
            k = PURE[rng.integers(len(PURE))]
            axis_k = 0 if abs(BASE[k]["d"][0]) > 0.99 else 1
            levels = [("levels_linear_x", 0, None, {"cause": "none"}),
                      ("levels_linear_y", 1, None, {"cause": "none"}),
                      ("levels_hardening", axis_k, (k, rng.uniform(0.015, 0.03)),
                       {"cause": "nonlinearity", "freq_hz": BASE[k]["f0"], "kind": "hardening",
                        "axis": "xy"[axis_k]})]
            for row, axis, cubic, want in levels:
                folder = os.path.join(base, f"s{seed}_{row}")
                os.makedirs(folder, exist_ok=True)
                write(os.path.join(folder, f"imp_{'xy'[axis]}.csv"),
                      f"impact test, hammer along {'xy'[axis]}, three force levels",
                      impact_levels(BASE, axis, cubic, rng))
                diagnose(twin, folder, want, tag, verbose, table, row)
            for kind, broadband in (("periodic", 0.0), ("broadband", 0.5)):
                speeds = rng.uniform(5000, 9000, 2)

                def tooth(f):
                    """Within 3 % of a tooth-passing harmonic of either speed."""
                    for r in speeds:
                        ft = 3 * r / 60
                        if abs(f / (max(round(f / ft), 1) * ft) - 1) < 0.03:
                            return True
                    return False
                tones = []
                while len(tones) < 2:
                    f = rng.uniform(30, 400)
                    if not tooth(f) and all(abs(f / x - 1) > 0.1 for x in tones):
                        tones.append(f)
                i = PURE[rng.integers(len(PURE))]
                sf = rng.uniform(0.75, 0.9)
                cases = [("healthy", BASE, [], {"cause": "none"}),
                         ("disturbance", BASE, [(f, rng.uniform(0.1, 0.4)) for f in tones],
                          {"cause": "disturbance", "freq_hz": tones}),
                         ("stiffness_loss",
                          with_mode(i, k=BASE[i]["k"] * sf, f0=BASE[i]["f0"] * sf ** 0.5), [],
                          {"cause": "mode_change", "freq_hz": BASE[i]["f0"],
                           "new_freq_hz": BASE[i]["f0"] * sf ** 0.5})]
                for name, modes, dist, want in cases:
                    row = f"milling_{kind}_{name}"
                    folder = os.path.join(base, f"s{seed}_{row}")
                    os.makedirs(folder, exist_ok=True)
                    change = [] if name == "stiffness_loss" else None
                    for rpm in speeds:
                        write(os.path.join(folder, f"mill_{rpm:.0f}.csv"),
                              f"down-milling, 3 teeth, {rpm:.0f} rpm, feed x",
                              milling(modes, rpm, dist, broadband, rng, change))
                    note = ""
                    if change:
                        rel, snr = max(change)
                        note = (f"; the loss changes the noise-free cuts by {100 * rel:.2f} % "
                                f"(RMS, {snr:.2f} x the sensor noise)")
                    ok = diagnose(twin, folder, want, f"{tag} at {speeds.round()} rpm", verbose,
                                  table, row, note)
                    if change and verbose and ok:
                        print(f"{tag} {row}: found{note}", file=sys.stderr, flush=True)
    which = "a one-pose twin (centre impact test)" if one_pose else "the campaign twin"
    print(f"## tryout-truth cases, {seeds} seeds per row, against {which}, defaults only\n")
    print("| row | right | causes found |")
    print("|---|---:|---|")
    for row, (ok, n, found) in table.items():
        causes = ", ".join(f"{c} {k}" for c, k in sorted(found.items()))
        print(f"| {row} | {ok}/{n} | {causes} |")
    ok = sum(t[0] for t in table.values())
    n = sum(t[1] for t in table.values())
    print(f"\nright in {ok}/{n} cases; {time.time() - t0:.0f} s")


if __name__ == "__main__":
    main()
