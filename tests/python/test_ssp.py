"""The milling process as its own FMU (`mtwin process-fmu`), wired to the twin FMU by an
SSP package (`mtwin ssp`) and co-simulated by a master that knows only FMI and SSP
(ssp_master.py): the stability limit it finds agrees with the Python process model
(milling.py) co-simulated with the same twin FMU, within 1 %, at three spindle speeds."""
import math
import subprocess
import zipfile
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from fmpy import read_model_description
from fmpy.validation import validate_fmu

from conftest import MTWIN, run
from milling import cosimulate, growth
from ssp_master import NS, run as run_ssp
from test_cosim import POSE, sd_limit

SPT = 100
PERIODS = 120


def limit(g_of_ap, ap0):
    """The depth where the growth ratio crosses 1: log-growth interpolated between 0.9
    and 1.1 times `ap0`, then one secant step."""
    a = [0.9 * ap0, 1.1 * ap0]
    lg = [math.log(g_of_ap(x)) for x in a]
    ap = a[0] - lg[0] * (a[1] - a[0]) / (lg[1] - lg[0])
    lga = math.log(g_of_ap(ap))
    k = 0 if abs(lg[0]) < abs(lg[1]) else 1
    return ap - lga * (ap - a[k]) / (lga - lg[k])


@pytest.fixture(scope="module")
def ssp(built, tmp_path_factory):
    d = tmp_path_factory.mktemp("ssp")
    out = d / "milling.ssp"
    run(MTWIN, "--quiet", "ssp", "--twin", built["dir"] / "twin.json",
        "--at", ",".join(map(str, POSE)), "--teeth", "2", "--immersion", "1",
        "--kt", "6e8", "--kr", "0.3", "--rpm", "7560", "--ap", "1e-3", "--out", out)
    return out


def test_the_package_names_both_fmus_and_the_four_connections(ssp, tmp_path):
    with zipfile.ZipFile(ssp) as z:
        names = set(z.namelist())
        assert {"SystemStructure.ssd", "resources/twin.fmu", "resources/cut.fmu"} <= names
        root = ET.fromstring(z.read("SystemStructure.ssd"))
        z.extract("resources/cut.fmu", tmp_path)
    conns = {(c.get("startElement"), c.get("startConnector"), c.get("endElement"), c.get("endConnector"))
             for c in root.iter(f"{{{NS['ssd']}}}Connection")}
    assert conns == {("twin", "dx", "cut", "dx"), ("twin", "dy", "cut", "dy"),
                     ("cut", "Fx", "twin", "Fx"), ("cut", "Fy", "twin", "Fy")}
    cut = str(tmp_path / "resources" / "cut.fmu")
    assert validate_fmu(cut) == []
    md = read_model_description(cut)
    for v in md.modelVariables:
        assert v.description, v.name
    params = {v.name: v for v in md.modelVariables if v.causality == "parameter"}
    assert params["rpm"].start == "7560.0" or float(params["rpm"].start) == 7560.0
    assert params["ap"].unit == "m" and params["kt"].unit == "N/m2"


@pytest.mark.parametrize("rpm", [5200.0, 7560.0, 10400.0])
def test_process_fmu_in_an_ssp_master_finds_the_python_models_stability_limit(built, ssp, tmp_path, rpm):
    ap_sd, _, _ = sd_limit(built["dir"] / "twin.json", rpm)
    tau = 60.0 / (rpm * 2)
    h = tau / SPT
    n = SPT * PERIODS
    fmu_dir = tmp_path / "py"
    with zipfile.ZipFile(built["fmu"]) as z:
        z.extractall(fmu_dir)

    def python_growth(ap):
        _, x, y = cosimulate(built["fmu"], fmu_dir, POSE, rpm, ap, steps_per_tooth=SPT, tooth_periods=PERIODS)
        return growth(x, y, SPT)

    runs = iter(range(1000))

    def ssp_growth(ap):
        over = {("cut", "rpm"): rpm, ("cut", "ap"): ap, ("cut", "kick"): 50.0,
                ("cut", "kick_duration"): 4.5 * h}
        r = np.array(run_ssp(ssp, tmp_path / f"s{next(runs)}", h, n, ("twin", ["dx", "dy"]), over))
        return growth(r[:, 0], r[:, 1], SPT)

    g_py, g_fmu = python_growth(ap_sd), ssp_growth(ap_sd)
    lim_py = limit(python_growth, ap_sd)
    lim_fmu = limit(ssp_growth, ap_sd)
    print(f"rpm {rpm}: SD {ap_sd*1e3:.3f} mm; growth at SD limit python {g_py:.4f}, FMU {g_fmu:.4f}; "
          f"limit python {lim_py*1e3:.3f} mm, FMU+SSP {lim_fmu*1e3:.3f} mm")
    assert abs(lim_fmu / lim_py - 1.0) < 0.01
    # and both near the semi-discretisation (the co-simulation's own time step and the
    # finite run set the agreement)
    assert abs(lim_fmu / ap_sd - 1.0) < 0.1
