"""Builds the FMUs the tests load: generated campaign -> `mtwin identify` -> `mtwin export`
(FMI 2.0, and `--fmi 3` for FMI 3.0),
and the reference prediction `mtwin simulate --hold zoh` on a record with moving axes."""
import io
import os
import subprocess
import pathlib
import sys

import numpy as np
import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
TARGET = pathlib.Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "target"))
MTWIN = TARGET / "release" / "mtwin"
FIXTURE = TARGET / "release" / "examples" / "fmu_fixture"
# the FMI/SSP master of examples/python (ssp_master.py) is what the SSP test drives
sys.path.insert(0, str(ROOT / "examples" / "python"))


def run(*args):
    r = subprocess.run([str(a) for a in args], capture_output=True, text=True)
    assert r.returncode == 0, f"{args}: {r.stderr}"
    return r


def load_csv(path):
    """A SPEC time-series CSV (`#` comment lines, then a header) as a structured array."""
    lines = [l for l in pathlib.Path(path).read_text().splitlines() if not l.startswith("#")]
    return np.genfromtxt(io.StringIO("\n".join(lines)), delimiter=",", names=True)


@pytest.fixture(scope="session")
def built(tmp_path_factory):
    d = tmp_path_factory.mktemp("fmu")
    run(FIXTURE, d)
    campaign = sorted((d / "campaign").glob("*.csv"))
    run(MTWIN, "--quiet", "identify", *campaign, "--fmin", "30", "--fmax", "2500", "--out", d / "twin.json")
    run(MTWIN, "--quiet", "export", "--twin", d / "twin.json", "--out", d / "twin.fmu")
    run(MTWIN, "--quiet", "export", "--twin", d / "twin.json", "--fmi", "3", "--out", d / "twin3.fmu")
    run(MTWIN, "--quiet", "simulate", "--twin", d / "twin.json", d / "moving.csv", "--out", d / "pred.csv")
    data = load_csv(d / "moving.csv")
    pred = load_csv(d / "pred.csv")
    return {"dir": d, "fmu": str(d / "twin.fmu"), "fmu3": str(d / "twin3.fmu"), "data": data, "pred": pred}


@pytest.fixture(scope="session")
def pkg(built):
    """The twin identified by the package from the conftest campaign, with the same options
    as the command line's twin.json."""
    mtwin = pytest.importorskip("mtwin", reason="the package is not installed: scripts/build-wheel.sh --install")
    campaign = sorted((built["dir"] / "campaign").glob("*.csv"))
    twin = mtwin.identify(campaign, fmin=30, fmax=2500)
    cli = mtwin.load(built["dir"] / "twin.json")
    return {"twin": twin, "cli": cli, "campaign": campaign}
