"""Stability lobes by co-simulation, with a master that knows only FMI and SSP.

    mtwin ssp --twin twin.json --at 0.3,0.3,0.2 --out milling.ssp
    python examples/python/ssp_lobes.py milling.ssp --twin twin.json --at 0.3,0.3,0.2

For each spindle speed the axial depth where the co-simulated cut (twin FMU + process
FMU, wired by the SSP's connections) turns from decaying to growing vibration is found
(log-growth interpolated, then one secant step) and printed next to the
semi-discretisation of `mtwin lobes` for the same twin. Needs fmpy and numpy (the
project's venv: scripts/setup-python.sh)."""
import argparse
import json
import math
import pathlib
import subprocess
import tempfile

import numpy as np

from ssp_master import bindings, run

ROOT = pathlib.Path(__file__).resolve().parents[2]


def growth(x, y, spt):
    """Late over early vibration amplitude (peak per tooth period): > 1 grows."""
    amp = np.hypot(x, y).reshape(-1, spt).max(axis=1)
    k = len(amp)
    return amp[int(0.9 * k):].mean() / amp[int(0.3 * k):int(0.4 * k)].mean()


def limit(g_of_ap, ap0):
    """Depth where the growth crosses 1 (log-growth between 0.9 and 1.1 x ap0, then one
    secant step)."""
    a = [0.9 * ap0, 1.1 * ap0]
    lg = [math.log(g_of_ap(x)) for x in a]
    ap = a[0] - lg[0] * (a[1] - a[0]) / (lg[1] - lg[0])
    lga = math.log(g_of_ap(ap))
    k = 0 if abs(lg[0]) < abs(lg[1]) else 1
    return ap - lga * (ap - a[k]) / (lga - lg[k])


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("ssp")
    p.add_argument("--twin", required=True, help="the twin file the SSP was made from (for mtwin lobes)")
    p.add_argument("--at", required=True)
    p.add_argument("--mtwin", default=str(ROOT / "target" / "release" / "mtwin"))
    p.add_argument("--rpm-min", type=float, default=4000.0)
    p.add_argument("--rpm-max", type=float, default=12000.0)
    p.add_argument("--speeds", type=int, default=9)
    p.add_argument("--steps-per-tooth", type=int, default=100)
    p.add_argument("--periods", type=int, default=120)
    a = p.parse_args()
    work = pathlib.Path(tempfile.mkdtemp())
    spt = a.steps_per_tooth
    cut = {k[1]: v for k, v in bindings(a.ssp).items() if k[0] == "cut"}
    teeth = int(round(cut["teeth"]))
    tool = ["--teeth", str(teeth), "--kt", str(cut["kt"]), "--kr", str(cut["kr"]),
            "--immersion", str(cut["immersion"]), "--helix", str(cut["helix_deg"]),
            "--diameter", str(cut["diameter"])] + ([] if cut["down"] >= 0.5 else ["--up"])
    print(f"{'rpm':>8} {'SD limit mm':>12} {'co-sim mm':>10} {'ratio':>6}")
    for rpm in np.geomspace(a.rpm_min, a.rpm_max, a.speeds):
        r = subprocess.run([a.mtwin, "--json", "lobes", "--twin", a.twin, "--at", a.at,
                            "--out", str(work / "l.csv"), "--rpm-min", str(rpm),
                            "--rpm-max", str(rpm * 1.001), "--speeds", "1", "--sd-speeds", "1",
                            "--sd-steps", "80", *tool], capture_output=True, text=True, check=True)
        ap_sd = json.loads(r.stdout)["sd"][0]["ap_lim_m"]
        h = 60.0 / (rpm * teeth) / spt
        runs = iter(range(10**6))

        def g(ap):
            over = {("cut", "rpm"): rpm, ("cut", "ap"): ap, ("cut", "kick"): 50.0,
                    ("cut", "kick_duration"): 4.5 * h}
            out = np.array(run(a.ssp, work / f"s{next(runs)}", h, spt * a.periods, ("twin", ["dx", "dy"]), over))
            return growth(out[:, 0], out[:, 1], spt)

        lim = limit(g, ap_sd) if math.isfinite(ap_sd) else float("nan")
        print(f"{rpm:8.0f} {ap_sd*1e3:12.3f} {lim*1e3:10.3f} {lim/ap_sd:6.3f}")


if __name__ == "__main__":
    main()
