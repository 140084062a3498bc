"""The mtwin FMU in real importers: fmpy (validation, simulate_fmu, a master loop on
FMU2Slave with misuse) and libcosimpy (Open Simulation Platform)."""
import ctypes
import shutil
import zipfile

import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu
from fmpy.fmi2 import FMU2Slave
from fmpy.validation import validate_fmu


def open_slave(fmu, unzip_dir, guid=None, name="inst"):
    md = read_model_description(fmu)
    s = FMU2Slave(
        guid=guid or md.guid,
        unzipDirectory=str(unzip_dir),
        modelIdentifier=md.coSimulation.modelIdentifier,
        instanceName=name,
    )
    return md, s


def refs(md):
    return {v.name: v.valueReference for v in md.modelVariables}


def unzip(fmu, d):
    with zipfile.ZipFile(fmu) as z:
        z.extractall(d)
    return d


def master_loop(slave, md, data, steps=None):
    r = refs(md)
    n = len(data) if steps is None else steps
    dt = data["t"][1] - data["t"][0]
    ins = [r["Fx"], r["Fy"], r["x"], r["y"], r["z"]]
    outs = [r["dx"], r["dy"]]
    y = np.zeros((n, 2))
    for i in range(n):
        slave.setReal(ins, [data["fx"][i], data["fy"][i], data["x"][i], data["y"][i], data["z"][i]])
        y[i] = slave.getReal(outs)
        slave.doStep(currentCommunicationPoint=i * dt, communicationStepSize=dt)
    return y


def start(slave):
    slave.instantiate()
    slave.setupExperiment(startTime=0.0)
    slave.enterInitializationMode()
    slave.exitInitializationMode()


def test_validate_fmu_finds_no_problem(built):
    assert validate_fmu(built["fmu"]) == []


def test_model_description_variables(built):
    md = read_model_description(built["fmu"])
    names = [v.name for v in md.modelVariables]
    assert names == ["Fx", "Fy", "x", "y", "z", "dx", "dy"]
    assert md.coSimulation.canHandleVariableCommunicationStepSize


def test_master_loop_agrees_with_mtwin_simulate_while_axes_move(built, tmp_path):
    md, s = open_slave(built["fmu"], unzip(built["fmu"], tmp_path / "u"))
    start(s)
    y = master_loop(s, md, built["data"])
    s.terminate()
    s.freeInstance()
    pred = built["pred"]
    for k, name in enumerate(["dx", "dy"]):
        ref = pred[name]
        err = np.max(np.abs(y[:, k] - ref)) / np.max(np.abs(ref))
        assert err < 1e-9, (name, err)


def test_simulate_fmu_with_input_signals(built):
    data = built["data"]
    dt = float(data["t"][1] - data["t"][0])
    sig = np.array(
        list(zip(data["t"], data["fx"], data["fy"], data["x"], data["y"], data["z"])),
        dtype=[("time", float), ("Fx", float), ("Fy", float), ("x", float), ("y", float), ("z", float)],
    )
    res = simulate_fmu(built["fmu"], start_time=0.0, stop_time=float(data["t"][-1]), step_size=dt,
                       output_interval=dt, input=sig, output=["dx", "dy"])
    # fmpy records the outputs after each doStep but before it applies the next inputs,
    # so only the small direct feedthrough differs from mtwin simulate (exact agreement
    # is checked by the master loop above)
    assert np.all(np.isfinite(res["dx"])) and np.all(np.isfinite(res["dy"]))
    for name in ("dx", "dy"):
        ref = built["pred"][name]
        n = min(len(ref), len(res))
        rel = np.linalg.norm(res[name][:n] - ref[:n]) / np.linalg.norm(ref[:n])
        assert rel < 5e-3, (name, rel)


def test_wrong_guid_is_rejected(built, tmp_path):
    md, s = open_slave(built["fmu"], unzip(built["fmu"], tmp_path / "u"), guid="{00000000-0000-0000-0000-000000000000}")
    with pytest.raises(Exception):
        s.instantiate()


def test_resource_path_with_space_and_non_ascii_letter(built, tmp_path):
    d = unzip(built["fmu"], tmp_path / "dir with space Müller")
    md, s = open_slave(built["fmu"], d)
    start(s)
    y = master_loop(s, md, built["data"], steps=200)
    s.terminate()
    s.freeInstance()
    assert np.allclose(y[:, 0], built["pred"]["dx"][:200], rtol=0, atol=1e-9 * np.max(np.abs(built["pred"]["dx"])))


def test_reset_reproduces_the_run(built, tmp_path):
    md, s = open_slave(built["fmu"], unzip(built["fmu"], tmp_path / "u"))
    start(s)
    a = master_loop(s, md, built["data"], steps=300)
    s.reset()
    s.setupExperiment(startTime=0.0)
    s.enterInitializationMode()
    s.exitInitializationMode()
    b = master_loop(s, md, built["data"], steps=300)
    s.terminate()
    s.freeInstance()
    assert np.array_equal(a, b)


def test_two_interleaved_instances_stay_independent(built, tmp_path):
    d = unzip(built["fmu"], tmp_path / "u")
    md, s1 = open_slave(built["fmu"], d, name="a")
    _, s2 = open_slave(built["fmu"], d, name="b")
    start(s1)
    start(s2)
    r = refs(md)
    data = built["data"]
    dt = data["t"][1] - data["t"][0]
    y1 = []
    for i in range(300):
        s1.setReal([r["Fx"], r["Fy"], r["x"], r["y"], r["z"]], [data["fx"][i], data["fy"][i], data["x"][i], data["y"][i], data["z"][i]])
        s2.setReal([r["Fx"]], [1000.0 * (i % 7)])  # something else entirely
        y1.append(s1.getReal([r["dx"]])[0])
        s2.getReal([r["dx"]])
        s1.doStep(i * dt, dt)
        s2.doStep(i * dt, dt)
    for s in (s1, s2):
        s.terminate()
        s.freeInstance()
    ref = built["pred"]["dx"][:300]
    assert np.max(np.abs(np.array(y1) - ref)) <= 1e-9 * np.max(np.abs(ref))


def test_misuse_returns_error_without_crashing(built, tmp_path):
    md, s = open_slave(built["fmu"], unzip(built["fmu"], tmp_path / "u"))
    s.instantiate()
    r = refs(md)
    with pytest.raises(Exception):  # doStep before initialization
        s.doStep(0.0, 1e-3)
    with pytest.raises(Exception):  # exit without enter
        s.exitInitializationMode()
    s.setupExperiment(startTime=0.0)
    s.enterInitializationMode()
    s.exitInitializationMode()
    with pytest.raises(Exception):  # unknown value reference
        s.getReal([999])
    with pytest.raises(Exception):  # setting an output
        s.setReal([r["dx"]], [1.0])
    # NULL pointers straight through ctypes: fmi2Error (3), no crash
    st = s.dll.fmi2GetReal(s.component, None, ctypes.c_size_t(2), None)
    assert st == 3
    st = s.dll.fmi2SetReal(s.component, None, ctypes.c_size_t(1), None)
    assert st == 3
    st = s.dll.fmi2DoStep(None, ctypes.c_double(0.0), ctypes.c_double(1e-3), 1)
    assert st == 3
    with pytest.raises(Exception):  # time does not follow
        s.doStep(5.0, 1e-3)
    # still usable after all that
    s.doStep(0.0, 1e-3)
    assert np.isfinite(s.getReal([r["dx"]])[0])
    s.terminate()
    s.freeInstance()


def test_variable_step_sizes_are_exact(built, tmp_path):
    d = unzip(built["fmu"], tmp_path / "u")
    md, a = open_slave(built["fmu"], d, name="a")
    _, b = open_slave(built["fmu"], d, name="b")
    r = refs(md)
    for s in (a, b):
        start(s)
        s.setReal([r["Fx"], r["x"], r["y"], r["z"]], [100.0, 0.3, 0.2, 0.1])
    t = 0.0
    for h in [1e-4, 3.3e-4, 2e-5, 7e-4]:
        a.doStep(t, h)
        t += h
    b.doStep(0.0, t)
    ya, yb = a.getReal([r["dx"]])[0], b.getReal([r["dx"]])[0]
    assert abs(ya - yb) <= 1e-9 * abs(yb)
    assert a.getRealStatus(2) == pytest.approx(t, abs=1e-15) if hasattr(a, "getRealStatus") else True
    for s in (a, b):
        s.terminate()
        s.freeInstance()


def test_fmu_state_get_set_and_serialize(built, tmp_path):
    md, s = open_slave(built["fmu"], unzip(built["fmu"], tmp_path / "u"))
    start(s)
    r = refs(md)
    data = built["data"]
    master_loop(s, md, data, steps=100)
    st = s.getFMUState()
    blob = s.serializeFMUState(st)
    dt = data["t"][1] - data["t"][0]
    def cont():
        out = []
        for i in range(100, 150):
            s.setReal([r["Fx"], r["Fy"], r["x"], r["y"], r["z"]], [data["fx"][i], data["fy"][i], data["x"][i], data["y"][i], data["z"][i]])
            out.append(s.getReal([r["dx"]])[0])
            s.doStep(i * dt, dt)
        return out
    a = cont()
    s.setFMUState(st)
    b = cont()
    st2 = s.deserializeFMUState(blob)
    s.setFMUState(st2)
    c = cont()
    s.freeFMUState(st)
    s.freeFMUState(st2)
    s.terminate()
    s.freeInstance()
    assert a == b == c


COSIM_SCRIPT = """
import json, sys
from libcosimpy.CosimExecution import CosimExecution
from libcosimpy.CosimSlave import CosimLocalSlave
from libcosimpy.CosimObserver import CosimObserver
from libcosimpy.CosimManipulator import CosimManipulator
fmu, vrs, vr_out = sys.argv[1], json.loads(sys.argv[2]), int(sys.argv[3])
ex = CosimExecution.from_step_size(step_size=100_000)  # 0.1 ms in integer nanoseconds
idx = ex.add_local_slave(local_slave=CosimLocalSlave(fmu_path=fmu, instance_name="tcp"))
obs = CosimObserver.create_last_value()
ex.add_observer(observer=obs)
man = CosimManipulator.create_override()
ex.add_manipulator(manipulator=man)
man.slave_real_values(idx, vrs, [100.0, 0.3, 0.2, 0.1])
assert ex.step(step_count=200)
print("RESULT", json.dumps(obs.last_real_values(slave_index=idx, variable_references=[vr_out])[0]))
"""


def test_libcosimpy_runs_the_fmu_like_fmpy(built, tmp_path):
    """Open Simulation Platform's libcosim, in its own process (two FMI libraries
    loading the same slave library into one Python process is not what either expects)."""
    import json
    import subprocess
    import sys

    pytest.importorskip("libcosimpy")
    md = read_model_description(built["fmu"])
    r = refs(md)
    out = subprocess.run(
        [sys.executable, "-c", COSIM_SCRIPT, built["fmu"], json.dumps([r["Fx"], r["x"], r["y"], r["z"]]), str(r["dx"])],
        capture_output=True, text=True,
    )
    assert out.returncode == 0, out.stderr[-2000:]
    lines = [l for l in out.stdout.splitlines() if l.startswith("RESULT ")]
    assert lines, out.stdout[-2000:]
    got = json.loads(lines[-1].split(" ", 1)[1])
    # the same constant force in fmpy, 200 steps of 0.1 ms
    _, s = open_slave(built["fmu"], unzip(built["fmu"], tmp_path / "u"))
    start(s)
    s.setReal([r["Fx"], r["x"], r["y"], r["z"]], [100.0, 0.3, 0.2, 0.1])
    for i in range(200):
        s.doStep(i * 1e-4, 1e-4)
    want = s.getReal([r["dx"]])[0]
    s.terminate()
    s.freeInstance()
    assert np.isfinite(got) and abs(got - want) <= 1e-9 * abs(want), (got, want)


def test_extended_twin_cubic_stiffness_and_vibration_agree_with_mtwin_simulate(built, tmp_path):
    """An extended twin (as `mtwin diagnose` writes it): a cubic modal stiffness and an
    external vibration are carried by the FMU exactly as `mtwin simulate --hold zoh` runs
    them, and the cubic term really acts (the outputs differ from the linear twin's)."""
    import json

    from conftest import MTWIN, load_csv, run

    d = built["dir"]
    twin = json.loads((d / "twin.json").read_text())
    lin = built["pred"]
    # a cubic term that matters: κ q² ≈ 0.3 at the record's largest modal amplitude
    k = 2
    b0 = max(abs(c["num"][k]["b0"]) for c in twin["poses"][0]["model"]["channels"])
    q = np.max(np.abs(lin["dx"])) / b0
    twin["extensions"] = {
        "cubic": [{"mode": k, "kappa": 0.3 / q**2}],
        "disturbance": [{"freq_hz": 50.0, "axis": "x", "a": 1e-7, "b": -2e-7}],
    }
    ext = tmp_path / "ext.json"
    ext.write_text(json.dumps(twin))
    fmu = tmp_path / "ext.fmu"
    run(MTWIN, "--quiet", "export", "--twin", ext, "--out", fmu)
    run(MTWIN, "--quiet", "simulate", "--twin", ext, d / "moving.csv", "--out", tmp_path / "p.csv")
    pred = load_csv(tmp_path / "p.csv")
    md, s = open_slave(str(fmu), unzip(str(fmu), tmp_path / "u"))
    start(s)
    y = master_loop(s, md, built["data"])
    s.terminate()
    s.freeInstance()
    for i, name in enumerate(["dx", "dy"]):
        scale = np.max(np.abs(pred[name]))
        assert np.max(np.abs(y[:, i] - pred[name])) / scale < 1e-9, name
    assert np.max(np.abs(pred["dx"] - lin["dx"])) / np.max(np.abs(lin["dx"])) > 1e-3


def test_model_description_explains_every_variable(built, capsys):
    """`fmpy.dump` shows a description and a unit on every variable and the measured box
    as min/max of the axis positions; the model description says when it was generated
    and where the twin came from; Outputs state the direct feedthrough."""
    import json

    import fmpy

    fmu = built["fmu"]
    md = read_model_description(fmu)
    twin = json.loads((built["dir"] / "twin.json").read_text())
    poses = np.array([p["pose"] for p in twin["poses"]])
    lo, hi = poses.min(axis=0), poses.max(axis=0)
    units = {u.name for u in md.unitDefinitions}
    assert {"N", "m"} <= units
    for v in md.modelVariables:
        assert v.description and len(v.description) > 40, v.name
        assert v.unit in units, (v.name, v.unit)
        if v.name in "xyz":
            a = "xyz".index(v.name)
            assert (float(v.min), float(v.max)) == (lo[a], hi[a]), v.name
            assert lo[a] <= float(v.start) <= hi[a], v.name
    desc = {v.name: v.description for v in md.modelVariables}
    assert "on the tool" in desc["Fx"] and "relative to the workpiece" in desc["dx"]
    assert "direct" in desc["dx"] and "feedthrough" in desc["dx"]
    assert md.generationDateAndTime and md.generationDateAndTime.endswith("Z")
    n = len(twin['poses'])
    assert (f"{n} poses" if n != 1 else "1 pose") in md.description and "identify" in md.description
    # every output depends on the forces of its channels (residual compliance) and the
    # axis positions; none on a force it has no channel to
    names = [v.name for v in md.modelVariables]
    for u in md.outputs:
        deps = {d.name for d in u.dependencies}
        out = u.variable.name[1]
        chans = [c for c in twin["channels"] if c["output"] == out]
        assert deps <= {"F" + c["input"] for c in chans} | {"x", "y", "z"}, (u.variable.name, deps)
        assert "F" + out in deps, (u.variable.name, deps)
    fmpy.dump(fmu)
    text = capsys.readouterr().out
    assert "on the tool" in text and "Description" in text, text
    assert names == ["Fx", "Fy", "x", "y", "z", "dx", "dy"]


def test_resources_hold_the_lean_twin(built):
    """No FRFs, plans or history in the FMU: the lean twin (pose models) and the twin's
    identity only, well under 1 MB."""
    import json

    with zipfile.ZipFile(built["fmu"]) as z:
        info = {i.filename: i.file_size for i in z.infolist()}
        lean = json.loads(z.read("resources/twin.json"))
    assert sum(n for f, n in info.items() if not f.startswith("binaries/")) < 1_000_000, info
    assert lean["schema"] == "mtwin-fmu-twin"
    assert lean["guid"] == read_model_description(built["fmu"]).guid
    text = json.dumps(lean)
    for absent in ('"frf"', '"previous_poses"', '"plan"'):
        assert absent not in text, absent
    assert lean["provenance"]["poses"] == len(lean["poses"])


def test_leaving_the_measured_box_logs_one_warning_per_excursion(built, tmp_path):
    """Axis positions outside the measured box: the model is clamped to the box and the
    FMI logger gets one warning per excursion (not one per step)."""
    from fmpy.fmi2 import fmi2CallbackFunctions, fmi2CallbackLoggerTYPE
    from fmpy.logging import addLoggerProxy

    got = []

    def logger(env, name, status, category, message):
        got.append((status, category.decode(), message.decode()))

    cb = fmi2CallbackFunctions()
    cb.logger = fmi2CallbackLoggerTYPE(logger)
    addLoggerProxy(ctypes.byref(cb))
    md, s = open_slave(built["fmu"], unzip(built["fmu"], tmp_path / "u"))
    s.instantiate(callbacks=cb)
    s.setupExperiment(startTime=0.0)
    s.enterInitializationMode()
    s.exitInitializationMode()
    r = refs(md)
    lo = [float(v.min) for v in md.modelVariables if v.name in "xyz"]
    hi = [float(v.max) for v in md.modelVariables if v.name in "xyz"]
    mid = [(a + b) / 2 for a, b in zip(lo, hi)]
    dt = 1e-4
    statuses = []
    for i in range(400):
        p = list(mid)
        if 100 <= i < 150:
            p[0] = hi[0] + 0.001 * (i - 99)  # out along x, further every step
        if 300 <= i < 350:
            p[1] = lo[1] - 0.2  # out along y
        s.setReal([r["Fx"], r["Fy"], r["x"], r["y"], r["z"]], [1.0, 0.5] + p)
        y = s.getReal([r["dx"], r["dy"]])
        assert np.all(np.isfinite(y))
        statuses.append(s.fmi2DoStep(s.component, i * dt, dt, 1))
    s.terminate()
    s.freeInstance()
    warnings = [g for g in got if g[0] == 1]
    assert len(warnings) == 2, got
    assert all(g[1] == "logStatusWarning" and "outside the measured box" in g[2] for g in warnings)
    assert "x = " in warnings[0][2] and "y = " in warnings[1][2], warnings
    assert not [g for g in got if g[0] > 1], got
