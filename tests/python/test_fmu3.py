"""The FMI 3.0 FMU (`mtwin export --fmi 3`) in fmpy: validation, simulate_fmu, a master
loop on FMU3Slave with moving axes against `mtwin simulate` and against the FMI 2.0 FMU of
the same twin, FMU state, misuse."""
import ctypes
import json
import zipfile

import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu
from fmpy.fmi3 import FMU3Slave
from fmpy.validation import validate_fmu

from conftest import MTWIN, load_csv, run
from test_fmu import master_loop as master_loop2
from test_fmu import open_slave as open_slave2
from test_fmu import start as start2
from test_fmu import unzip

INPUTS = ["Fx", "Fy", "x", "y", "z"]


def open_slave3(fmu, unzip_dir, token=None, name="inst3"):
    md = read_model_description(fmu)
    s = FMU3Slave(
        guid=token or md.instantiationToken,
        unzipDirectory=str(unzip_dir),
        modelIdentifier=md.coSimulation.modelIdentifier,
        instanceName=name,
    )
    return md, s


def refs(md):
    return {v.name: v.valueReference for v in md.modelVariables}


def start3(slave):
    slave.instantiate()
    slave.enterInitializationMode(startTime=0.0)
    slave.exitInitializationMode()


def master_loop3(slave, md, data, steps=None):
    """Inputs set at t, outputs read at t, then doStep(t, dt)."""
    r = refs(md)
    n = len(data) if steps is None else steps
    dt = data["t"][1] - data["t"][0]
    ins = [r[v] for v in INPUTS]
    outs = [r["dx"], r["dy"], r["time"]]
    y = np.zeros((n, 2))
    for i in range(n):
        slave.setFloat64(ins, [data["fx"][i], data["fy"][i], data["x"][i], data["y"][i], data["z"][i]])
        dx, dy, t = slave.getFloat64(outs)
        assert abs(t - i * dt) <= 1e-12 * max(1.0, i * dt), (t, i * dt)
        y[i] = (dx, dy)
        event, terminate, early, last = slave.doStep(currentCommunicationPoint=i * dt, communicationStepSize=dt)
        assert not (event or terminate or early)
    return y


def max_rel_dev(y, ref):
    return np.max(np.abs(y - ref)) / np.max(np.abs(ref))


def input_signal(data, x=None):
    """fmpy input table of a record (the axis positions fixed at `x` when given)."""
    cols = [data["t"], data["fx"], data["fy"]]
    cols += [np.full(len(data), v) for v in x] if x is not None else [data["x"], data["y"], data["z"]]
    return np.array(
        list(zip(*cols)),
        dtype=[("time", float), ("Fx", float), ("Fy", float), ("x", float), ("y", float), ("z", float)],
    )


def test_validate_fmu3_finds_no_problem(built):
    problems = validate_fmu(built["fmu3"])
    print("fmpy.validate_fmu(FMI 3.0 FMU):", problems)
    assert problems == []


def test_fmu3_has_the_fmi2_variables_and_the_x86_64_linux_binary(built):
    md2 = read_model_description(built["fmu"])
    md3 = read_model_description(built["fmu3"])
    assert md3.fmiVersion == "3.0" and md3.instantiationToken == md2.guid
    assert md3.coSimulation.canHandleVariableCommunicationStepSize
    v2 = {v.name: v for v in md2.modelVariables}
    v3 = {v.name: v for v in md3.modelVariables}
    assert list(v3) == ["time"] + list(v2)
    assert v3["time"].causality == "independent" and v3["time"].valueReference == len(v2)
    units3 = {u.name for u in md3.unitDefinitions}
    for name, a in v2.items():
        b = v3[name]
        assert b.type == "Float64", name
        for attr in ("valueReference", "causality", "variability", "description", "min", "max", "start"):
            assert str(getattr(a, attr)) == str(getattr(b, attr)), (name, attr, getattr(a, attr), getattr(b, attr))
        # quantity and unit through the declared type (units in UnitDefinitions)
        t = b.declaredType
        assert (t.quantity, t.unit) == (a.quantity, a.unit), (name, t.quantity, t.unit)
        assert t.unit in units3, (name, t.unit)
    deps2 = {u.variable.name: sorted(d.name for d in u.dependencies) for u in md2.outputs}
    deps3 = {u.variable.name: sorted(d.name for d in u.dependencies) for u in md3.outputs}
    assert deps2 == deps3
    with zipfile.ZipFile(built["fmu3"]) as z3, zipfile.ZipFile(built["fmu"]) as z2:
        assert z3.read("binaries/x86_64-linux/mtwin_tcp.so") == z2.read("binaries/linux64/mtwin_tcp.so")
        assert z3.read("resources/twin.json") == z2.read("resources/twin.json")
        assert not [n for n in z3.namelist() if n.startswith("binaries/linux64")]


def test_fmu3_master_loop_agrees_with_mtwin_simulate_and_with_fmi2(built, tmp_path):
    md3, s3 = open_slave3(built["fmu3"], unzip(built["fmu3"], tmp_path / "u3"))
    start3(s3)
    y3 = master_loop3(s3, md3, built["data"])
    s3.terminate()
    s3.freeInstance()
    md2, s2 = open_slave2(built["fmu"], unzip(built["fmu"], tmp_path / "u2"))
    start2(s2)
    y2 = master_loop2(s2, md2, built["data"])
    s2.terminate()
    s2.freeInstance()
    pred = built["pred"]
    for k, name in enumerate(["dx", "dy"]):
        e3 = max_rel_dev(y3[:, k], pred[name])
        e2 = max_rel_dev(y2[:, k], pred[name])
        e23 = max_rel_dev(y3[:, k], y2[:, k])
        print(f"{name}: max |FMI3 - simulate| / peak {e3:.2e}, FMI2 {e2:.2e}, FMI3 vs FMI2 {e23:.2e}")
        assert e3 < 1e-9 and e2 < 1e-9 and e23 <= 1e-9, (name, e3, e2, e23)


def test_fmu3_simulate_fmu_agrees_with_fmi2_and_without_feedthrough_with_mtwin_simulate(built, tmp_path):
    """simulate_fmu runs the FMI 3.0 FMU like the FMI 2.0 one (≤ 1e-9 on the moving
    record). fmpy records the outputs after each doStep, before it applies the next inputs,
    so its samples carry the force and pose of the step before (see test_fmu.py); for a
    twin without residual compliance at fixed axis positions that makes no difference, and
    there simulate_fmu of the FMI 3.0 FMU is `mtwin simulate` to 1e-9."""
    data = built["data"]
    dt = float(data["t"][1] - data["t"][0])
    stop = float(data["t"][-1])
    kw = dict(start_time=0.0, stop_time=stop, step_size=dt, output_interval=dt, output=["dx", "dy"])
    r3 = simulate_fmu(built["fmu3"], input=input_signal(data), **kw)
    r2 = simulate_fmu(built["fmu"], input=input_signal(data), **kw)
    assert len(r3) == len(r2) == len(data)
    for name in ("dx", "dy"):
        assert np.all(np.isfinite(r3[name]))
        e = max_rel_dev(r3[name], r2[name])
        print(f"simulate_fmu {name}: FMI3 vs FMI2 {e:.2e}")
        assert e <= 1e-9, (name, e)

    # no direct feedthrough, axes held: simulate_fmu == mtwin simulate
    d = built["dir"]
    twin = json.loads((d / "twin.json").read_text())
    for p in twin["poses"]:
        for c in p["model"]["channels"]:
            c["d"] = 0.0
    nod = tmp_path / "nod.json"
    nod.write_text(json.dumps(twin))
    fmu3 = tmp_path / "nod3.fmu"
    run(MTWIN, "--quiet", "export", "--twin", nod, "--fmi", "3", "--out", fmu3)
    pose = [float(np.mean(data[a])) for a in "xyz"]
    rec = tmp_path / "fixed.csv"
    table = np.column_stack([data["t"], data["fx"], data["fy"]] + [np.full(len(data), v) for v in pose])
    np.savetxt(rec, table, delimiter=",", header="t,fx,fy,x,y,z", comments="", fmt="%.17g")
    run(MTWIN, "--quiet", "simulate", "--twin", nod, rec, "--out", tmp_path / "p.csv")
    pred = load_csv(tmp_path / "p.csv")
    res = simulate_fmu(str(fmu3), input=input_signal(data, pose), **kw)
    for name in ("dx", "dy"):
        e = max_rel_dev(res[name], pred[name])
        print(f"simulate_fmu {name} (no feedthrough, fixed axes): FMI3 vs mtwin simulate {e:.2e}")
        assert e <= 1e-9, (name, e)


def test_fmu3_wrong_token_and_event_mode_are_refused(built, tmp_path):
    d = unzip(built["fmu3"], tmp_path / "u")
    _, s = open_slave3(built["fmu3"], d, token="{00000000-0000-0000-0000-000000000000}")
    with pytest.raises(Exception):
        s.instantiate()
    _, s = open_slave3(built["fmu3"], d)
    with pytest.raises(Exception):
        s.instantiate(eventModeUsed=True)


def test_fmu3_misuse_returns_error_without_crashing(built, tmp_path):
    md, s = open_slave3(built["fmu3"], unzip(built["fmu3"], tmp_path / "u"))
    s.instantiate()
    r = refs(md)
    with pytest.raises(Exception):  # doStep before initialization
        s.doStep(0.0, 1e-3)
    with pytest.raises(Exception):  # exit without enter
        s.exitInitializationMode()
    s.enterInitializationMode(startTime=0.0)
    s.exitInitializationMode()
    with pytest.raises(Exception):  # unknown value reference
        s.getFloat64([999])
    with pytest.raises(Exception):  # setting an output
        s.setFloat64([r["dx"]], [1.0])
    with pytest.raises(Exception):  # setting the independent variable
        s.setFloat64([r["time"]], [1.0])
    with pytest.raises(Exception):  # no event mode
        s.enterStepMode()
    with pytest.raises(Exception):  # no Int32 variables
        s.getInt32([0])
    # NULL pointers and mismatched lengths straight through ctypes: fmi3Error (3)
    assert s.dll.fmi3GetFloat64(s.component, None, ctypes.c_size_t(2), None, ctypes.c_size_t(2)) == 3
    vrs = (ctypes.c_uint32 * 2)(r["dx"], r["dy"])
    vals = (ctypes.c_double * 2)()
    assert s.dll.fmi3GetFloat64(s.component, vrs, ctypes.c_size_t(2), vals, ctypes.c_size_t(1)) == 3
    assert s.dll.fmi3DoStep(None, ctypes.c_double(0.0), ctypes.c_double(1e-3), ctypes.c_bool(True), None, None, None, None) == 3
    with pytest.raises(Exception):  # time does not follow
        s.doStep(5.0, 1e-3)
    s.doStep(0.0, 1e-3)
    assert np.isfinite(s.getFloat64([r["dx"]])[0])
    s.terminate()
    s.freeInstance()


def test_fmu3_reset_and_fmu_state(built, tmp_path):
    md, s = open_slave3(built["fmu3"], unzip(built["fmu3"], tmp_path / "u"))
    start3(s)
    data = built["data"]
    a = master_loop3(s, md, data, steps=200)
    s.reset()
    start3(s)
    b = master_loop3(s, md, data, steps=100)
    st = s.getFMUState()
    blob = s.serializeFMUState(st)
    r = refs(md)
    dt = data["t"][1] - data["t"][0]

    def cont():
        out = []
        for i in range(100, 200):
            s.setFloat64([r[v] for v in INPUTS], [data["fx"][i], data["fy"][i], data["x"][i], data["y"][i], data["z"][i]])
            out.append(s.getFloat64([r["dx"]])[0])
            s.doStep(i * dt, dt)
        return out

    c1 = cont()
    s.setFMUState(st)
    c2 = cont()
    st2 = s.deserializeFMUState(blob)
    s.setFMUState(st2)
    c3 = cont()
    s.freeFMUState(st)
    s.freeFMUState(st2)
    s.terminate()
    s.freeInstance()
    assert np.array_equal(a[:100], b)
    assert c1 == c2 == c3 == list(a[100:200, 0])
