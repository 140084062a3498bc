"""A time-domain milling process model co-simulated with the mtwin FMU (fmpy FMU2Slave):
the FMU gives the tool-tip displacement for the cutting force, the process model keeps
the delay line and computes the regenerative force

    h_j(t)  = sin(phi_j) * (x(t) - x(t - tau)) + cos(phi_j) * (y(t) - y(t - tau))
    F_x     = sum_j g(phi_j) * ap * Kt * (-cos(phi_j) - Kr sin(phi_j)) * h_j
    F_y     = sum_j g(phi_j) * ap * Kt * ( sin(phi_j) - Kr cos(phi_j)) * h_j

(dynamic chip = displacement one tooth period ago minus now, in the sign convention of
identify::lobes: phi_j = Omega t + 2 pi j / N clockwise from +y, feed along +x; the
static feed term adds a periodic force that does not change stability and is left out).
Straight flutes; down milling; mechanistic coefficients Kt, Kr.
"""
import math

import numpy as np
from fmpy import read_model_description
from fmpy.fmi2 import FMU2Slave


def engagement(immersion, down=True):
    if down:
        return math.acos(max(-1.0, min(1.0, 2.0 * immersion - 1.0))), math.pi
    return 0.0, math.acos(max(-1.0, min(1.0, 1.0 - 2.0 * immersion)))


def cosimulate(fmu, unzip_dir, pose, rpm, ap, teeth=2, kt=6e8, kr=0.3, immersion=1.0,
               steps_per_tooth=200, tooth_periods=150, kick=50.0):
    """Runs the cut; returns (time, x, y) of the tool tip, sampled every step."""
    md = read_model_description(fmu)
    r = {v.name: v.valueReference for v in md.modelVariables}
    s = FMU2Slave(guid=md.guid, unzipDirectory=str(unzip_dir),
                  modelIdentifier=md.coSimulation.modelIdentifier, instanceName="cut")
    s.instantiate()
    s.setupExperiment(startTime=0.0)
    s.enterInitializationMode()
    s.exitInitializationMode()
    s.setReal([r["x"], r["y"], r["z"]], list(pose))
    tau = 60.0 / (rpm * teeth)
    h = tau / steps_per_tooth
    om = 2.0 * math.pi * rpm / 60.0
    st, ex = engagement(immersion)
    n = steps_per_tooth * tooth_periods
    m = steps_per_tooth
    hist = np.zeros((m, 2))  # ring of r at the last m steps
    out = np.zeros((n, 2))
    vin = [r["Fx"], r["Fy"]]
    vout = [r["dx"], r["dy"]]
    for i in range(n):
        t = i * h
        now = s.getReal(vout)
        old = hist[i % m] if i >= m else (0.0, 0.0)
        dx, dy = now[0] - old[0], now[1] - old[1]
        fx = fy = 0.0
        for j in range(teeth):
            phi = (om * t + 2.0 * math.pi * j / teeth) % (2.0 * math.pi)
            if st <= phi <= ex:
                sn, co = math.sin(phi), math.cos(phi)
                hh = sn * dx + co * dy
                fx += ap * kt * (-co - kr * sn) * hh
                fy += ap * kt * (sn - kr * co) * hh
        if i < 5:  # a small tap starts the vibration
            fx += kick
            fy += kick
        s.setReal(vin, [fx, fy])
        hist[i % m] = now
        out[i] = now
        s.doStep(t, h)
    s.terminate()
    s.freeInstance()
    return np.arange(n) * h, out[:, 0], out[:, 1]


def growth(x, y, steps_per_tooth):
    """Ratio of the vibration amplitude (peak |r| per tooth period) late in the cut to
    the amplitude early on: > 1 grows (chatter), < 1 decays (stable)."""
    amp = np.hypot(x, y).reshape(-1, steps_per_tooth).max(axis=1)
    k = len(amp)
    early = amp[int(0.3 * k):int(0.4 * k)].mean()
    late = amp[int(0.9 * k):].mean()
    return late / early
