"""Quickstart of the Python package `mtwin`: a real impact-hammer test (5 hits, pyFRF's
data) -> FRF -> twin -> FMU, simulated in fmpy against the twin itself -> a figure.

    bash scripts/build-wheel.sh --install          # once: the wheel into .venv
    .venv/bin/python examples/python/quickstart.py [OUT.png]

Run from the repository root (the data is ../shared/data/... relative to it).
"""
import sys
import tempfile
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from fmpy import simulate_fmu  # noqa: E402

import mtwin  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / ".." / "shared" / "data" / "pyfrf_impact_hammer" / "impact_5hits.csv"


def read_csv(path):
    """The time-series CSV as columns (`#` lines are comments)."""
    lines = [l for l in Path(path).read_text().splitlines() if not l.startswith("#")]
    names = lines[0].split(",")
    values = np.loadtxt(lines[1:], delimiter=",")
    return {n: values[:, j] for j, n in enumerate(names)}


def main(out_png="quickstart.png"):
    d = read_csv(DATA)
    # 1. FRF (receptance, the accelerometer's response integrated) with coherence
    est = mtwin.frf(d["t"], d["fx"], d["ax"], kind="acceleration")
    print(f"FRF: {est.method}; {len(est.f_hz)} lines, {est.averages} hits averaged")
    # 2. the twin (band, order and weighting chosen from the data)
    twin = mtwin.identify([{"t": d["t"], "fx": d["fx"], "ax": d["ax"]}], name="pyfrf beam")
    pose = twin.poses[0]
    modes = twin.info["poses"][0]["model"]["modes"]
    print(f"twin: {twin!r}; {len(modes)} modes")
    model = twin.eval(pose, est.f_hz)
    # 3. the FMU, simulated by fmpy for one measured hit, and the twin's own simulation
    with tempfile.TemporaryDirectory() as tmp:
        fmu = Path(tmp) / "beam.fmu"
        twin.export_fmu(fmu)
        dt = d["t"][1] - d["t"][0]
        n = int(0.25 / dt)
        t, f = d["t"][:n] - d["t"][0], d["fx"][:n]
        sig = np.zeros(n, dtype=[("time", float), ("Fx", float), ("x", float), ("y", float), ("z", float)])
        sig["time"], sig["Fx"] = t, f  # at the measured pose, 0, 0, 0
        res = simulate_fmu(str(fmu), start_time=0.0, stop_time=t[-1], step_size=dt, output_interval=dt,
                           input=sig, output=["dx"])
    y = twin.simulate(t, f, pose)[:, 0]
    m = min(len(res), len(y))
    dev = np.max(np.abs(res["dx"][:m] - y[:m])) / np.max(np.abs(y[:m]))
    # fmpy records the outputs before it applies the next inputs: the direct feedthrough
    # lags one step (an FMI master that sets inputs first gets Twin.simulate exactly)
    print(f"FMU in fmpy vs Twin.simulate: max deviation {dev:.1e} of the peak")

    fig, ax = plt.subplots(3, 1, figsize=(8, 9))
    band = (est.f_hz > 0) & (est.f_hz <= twin.info["poses"][0]["band_hz"][1] * 1.2)
    ax[0].semilogy(est.f_hz[band], np.abs(est.h[band, 0, 0]), label="measured H1")
    ax[0].semilogy(est.f_hz[band], np.abs(model.h[band, 0, 0]), "--", label="twin")
    ax[0].set_ylabel("|H| [m/N]")
    ax[0].legend()
    ax[1].plot(est.f_hz[band], est.coherence[band, 0, 0])
    ax[1].set_ylabel("coherence")
    ax[1].set_xlabel("frequency [Hz]")
    ax[2].plot(res["time"][:m], res["dx"][:m], label="FMU (fmpy)")
    ax[2].plot(t[:m], y[:m], "--", label="Twin.simulate")
    ax[2].set_xlabel("time [s]")
    ax[2].set_ylabel("dx [m]")
    ax[2].legend()
    fig.suptitle(f"mtwin quickstart: {DATA.name}")
    fig.tight_layout()
    fig.savefig(out_png, dpi=100)
    print(f"figure -> {out_png}")
    return dev


if __name__ == "__main__":
    main(*sys.argv[1:])
