"""End to end: the FMU, the twin and the theory agree. A regenerative milling process
model co-simulated with the FMU in fmpy becomes unstable at the axial depth the
semi-discretisation (`mtwin lobes`) predicts for the same twin, within 5 %: stable at 0.95x,
chatter at 1.05x of the limit."""
import json
import subprocess
import zipfile

import pytest

from conftest import MTWIN
from milling import cosimulate, growth

POSE = (0.3, 0.3, 0.2)
RPM = 7560.0
SPT = 200


def sd_limit(twin, rpm=RPM):
    r = subprocess.run(
        [str(MTWIN), "--json", "lobes", "--twin", str(twin), "--at", ",".join(map(str, POSE)),
         "--out", str(twin.parent / "lobes.csv"), "--teeth", "2", "--immersion", "1",
         "--kt", "6e8", "--kr", "0.3", "--rpm-min", str(rpm), "--rpm-max", str(rpm * 1.001),
         "--speeds", "1", "--sd-speeds", "1", "--sd-steps", "80"],
        capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    d = json.loads(r.stdout)
    return d["sd"][0]["ap_lim_m"], d["zoa"][0]["ap_lim_m"], d["sd"][0]["chatter_hz"]


@pytest.mark.parametrize("factor,unstable", [(0.95, False), (1.05, True)])
def test_cosimulated_cut_agrees_with_semi_discretisation(built, tmp_path, factor, unstable):
    ap_sd, ap_zoa, f_chatter = sd_limit(built["dir"] / "twin.json")
    assert 1e-4 < ap_sd < 1.0
    d = tmp_path / "u"
    with zipfile.ZipFile(built["fmu"]) as z:
        z.extractall(d)
    t, x, y = cosimulate(built["fmu"], d, POSE, RPM, factor * ap_sd, steps_per_tooth=SPT, tooth_periods=150)
    g = growth(x, y, SPT)
    print(f"rpm {RPM}: SD limit {ap_sd*1e3:.2f} mm (ZOA {ap_zoa*1e3:.2f} mm, chatter {f_chatter:.0f} Hz); "
          f"ap = {factor} x limit: growth {g:.3f}")
    assert (g > 1.0) == unstable, g
