#!/usr/bin/env python3
"""Full cross-check of the co-simulation against the stability lobes: at several spindle
speeds, the axial depth where the co-simulated cut (tests/python/milling.py: process
model + the FMU in fmpy) starts to chatter is found by bisection and compared with the
semi-discretisation and zero-order limits of `mtwin lobes` for the same twin and pose.
Writes cosim_sweep.csv and cosim_sweep.svg (plot) and prints a table.

Usage: .venv/bin/python scripts/cosim_sweep.py TWIN.json TWIN.fmu X,Y,Z [rpm ...]
"""
import json
import pathlib
import subprocess
import sys
import tempfile
import zipfile

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "python"))
from milling import cosimulate, growth  # noqa: E402

MTWIN = ROOT / "target" / "release" / "mtwin"


def lobes(twin, pose, rpm):
    r = subprocess.run([str(MTWIN), "--json", "lobes", "--twin", twin, "--at", pose, "--out",
                        str(pathlib.Path(tempfile.gettempdir()) / "sweep_lobes.csv"),
                        "--teeth", "2", "--immersion", "1", "--kt", "6e8", "--kr", "0.3",
                        "--rpm-min", str(rpm), "--rpm-max", str(rpm * 1.001), "--speeds", "1",
                        "--sd-speeds", "1", "--sd-steps", "80"], capture_output=True, text=True, check=True)
    d = json.loads(r.stdout)
    return d["sd"][0]["ap_lim_m"], d["zoa"][0]["ap_lim_m"]


def write_svg(rows, path):
    """A plain SVG plot: limiting depth vs spindle speed for the three methods."""
    w, h, m = 720, 360, 60
    xs = [r[0] for r in rows]
    ys = [v * 1e3 for r in rows for v in r[1:]]
    x0, x1 = min(xs) * 0.95, max(xs) * 1.05
    y1 = max(ys) * 1.1
    px = lambda x: m + (x - x0) / (x1 - x0) * (w - 2 * m)
    py = lambda y: h - m - y / y1 * (h - 2 * m)
    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" font-family="sans-serif" font-size="12">',
           f'<rect width="{w}" height="{h}" fill="white"/>',
           f'<line x1="{m}" y1="{h-m}" x2="{w-m}" y2="{h-m}" stroke="black"/><line x1="{m}" y1="{m}" x2="{m}" y2="{h-m}" stroke="black"/>',
           f'<text x="{w/2}" y="{h-20}" text-anchor="middle">spindle speed [rpm]</text>',
           f'<text x="15" y="{h/2}" transform="rotate(-90 15 {h/2})" text-anchor="middle">limiting axial depth [mm]</text>']
    for k, (col, label) in enumerate([("#d62728", "co-simulation (FMU + process model)"), ("#1f77b4", "semi-discretisation"), ("#2ca02c", "zero-order")]):
        pts = " ".join(f"{px(r[0]):.1f},{py(r[1 + k] * 1e3):.1f}" for r in rows)
        out.append(f'<polyline points="{pts}" fill="none" stroke="{col}" stroke-width="1.5"/>')
        for r in rows:
            out.append(f'<circle cx="{px(r[0]):.1f}" cy="{py(r[1 + k] * 1e3):.1f}" r="3" fill="{col}"/>')
        out.append(f'<text x="{w-m-250}" y="{m + 15 * k}" fill="{col}">{label}</text>')
    for r in rows:
        out.append(f'<text x="{px(r[0]):.1f}" y="{h-m+15}" text-anchor="middle">{r[0]:.0f}</text>')
    for v in range(0, int(y1) + 1, max(1, int(y1 / 5))):
        out.append(f'<text x="{m-5}" y="{py(v):.1f}" text-anchor="end">{v}</text>')
    out.append("</svg>")
    pathlib.Path(path).write_text("\n".join(out))


def main():
    twin, fmu, pose = sys.argv[1], sys.argv[2], sys.argv[3]
    speeds = [float(v) for v in sys.argv[4:]] or [3500.0, 5555.0, 7560.0, 10287.0]
    p = tuple(float(v) for v in pose.split(","))
    d = pathlib.Path(tempfile.mkdtemp())
    with zipfile.ZipFile(fmu) as z:
        z.extractall(d)
    rows = []
    for rpm in speeds:
        sd, zoa = lobes(twin, pose, rpm)
        lo, hi = 0.7 * sd, 1.3 * sd
        for _ in range(6):
            mid = 0.5 * (lo + hi)
            _, x, y = cosimulate(fmu, d, p, rpm, mid, steps_per_tooth=200, tooth_periods=150)
            if growth(x, y, 200) > 1.0:
                hi = mid
            else:
                lo = mid
        co = 0.5 * (lo + hi)
        rows.append((rpm, co, sd, zoa))
        print(f"{rpm:8.0f} rpm: co-simulation {co*1e3:7.2f} mm, semi-discretisation {sd*1e3:7.2f} mm "
              f"({100*(co/sd-1):+5.1f} %), zero-order {zoa*1e3:7.2f} mm ({100*(zoa/sd-1):+5.1f} %)", flush=True)
    write_svg(rows, "cosim_sweep.svg")
    with open("cosim_sweep.csv", "w") as f:
        f.write("rpm,ap_cosim_m,ap_sd_m,ap_zoa_m\n")
        for r in rows:
            f.write(",".join(str(v) for v in r) + "\n")


if __name__ == "__main__":
    main()
