"""A fleet of machines on Dask: for every machine folder (a twin and new operating data),
the drift check, a refit where the twin drifted, a fresh FMU, and one summary table — as
Dask tasks on dask.distributed (a LocalCluster by default, any cluster by address).

Layout of a fleet folder (``generate`` makes one)::

    FLEET/<machine>/twin.json        the machine's current twin
    FLEET/<machine>/data/*.csv       its new operating records (forces, responses, axes)
    FLEET/<machine>/out/twin.json    written here: the refitted (or unchanged) twin
    FLEET/<machine>/out/twin.fmu     written here: its FMU

Every output is written atomically by the library (temporary file + rename), and a task
is a pure function of its folder, so a task rerun after a worker died writes the same
files again: no twin is lost or half-written.

    .venv/bin/python examples/python/fleet_dask.py generate FLEET --machines 50 [--base TWIN.json]
    .venv/bin/python examples/python/fleet_dask.py run FLEET [--workers 2 | --scheduler tcp://HOST:8786] [--serial]
    .venv/bin/python examples/python/fleet_dask.py bench [--machines 50] [--workers 2] [--kill]

``bench`` generates a fleet in a temporary folder, runs it serially and on the cluster,
checks that the results are equal (``--kill``: with a worker killed mid-run) and prints
the table and the machines per minute of both.
"""
from __future__ import annotations

import argparse
import json
import os
import pathlib
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import zipfile

import numpy as np

import mtwin

ROOT = pathlib.Path(__file__).resolve().parents[2]
TARGET = pathlib.Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "target"))

# the columns of the summary table (timing excluded: it is what may differ between runs)
COLUMNS = ["machine", "drift_fit_pct", "updated", "fit_after_pct", "mode1_before_hz", "mode1_after_hz",
           "history", "guid"]


# ---------------------------------------------------------------- generating a fleet
def base_twin(work: pathlib.Path) -> pathlib.Path:
    """A small twin to copy: the FMU tests' 2×2×1 campaign of the virtual machine
    (target/release/examples/fmu_fixture), identified by the package."""
    fixture = TARGET / "release" / "examples" / "fmu_fixture"
    subprocess.run([str(fixture), str(work)], check=True, capture_output=True)
    twin = mtwin.identify(sorted((work / "campaign").glob("*.csv")), fmin=30, fmax=2500, name="base")
    twin.save(work / "base.json")
    return work / "base.json"


def _scaled(info: dict, factor: float, name: str) -> dict:
    info = json.loads(json.dumps(info))
    info["name"] = name
    for p in info["poses"]:
        for m in p["model"]["modes"]:
            m["wn"] *= factor
    return info


def _write_csv(rec: dict, path: pathlib.Path) -> None:
    names = list(rec)
    np.savetxt(path, np.column_stack([rec[n] for n in names]), delimiter=",", header=",".join(names),
               comments="", fmt="%.17g")


def generate(fleet: pathlib.Path, base: pathlib.Path, machines: int, seed: int = 1) -> None:
    """`machines` copies of the twin `base`, each with one operating record (0.5 s at
    6.4 kHz, random forces along x and y, axes moving through the measured box) simulated
    from a changed twin: every third machine worn (natural frequencies -4 %), the others
    as identified (+1 % noise on the responses)."""
    info = mtwin.load(base).info
    poses = np.array([p["pose"] for p in info["poses"]])
    lo, hi = poses.min(axis=0), poses.max(axis=0)
    rng = np.random.default_rng(seed)
    n, fs = 3200, 6400.0
    t = np.arange(n) / fs
    for i in range(machines):
        d = fleet / f"machine-{i:03d}"
        (d / "data").mkdir(parents=True, exist_ok=True)
        name = d.name
        (d / "twin.json").write_text(json.dumps(_scaled(info, 1.0, name)))
        truth_path = d / ".truth.json"
        truth_path.write_text(json.dumps(_scaled(info, 0.96 if i % 3 == 0 else 1.0, name)))
        truth = mtwin.load(truth_path)
        truth_path.unlink()
        f = rng.normal(0.0, 50.0, (n, 2))
        u = 0.5 + 0.5 * np.sin(2 * np.pi * np.outer(t, [1.0, 0.7, 0.3]) + rng.uniform(0, 6, 3))
        pos = lo + (hi - lo) * u
        y = truth.simulate(t, f, pos, inputs="xy", hold="band")  # as a sensor sees it
        y = y + 0.01 * np.std(y) * rng.standard_normal(y.shape)
        _write_csv(mtwin.record(t, f, y, poses=pos, inputs="xy", outputs="xy"), d / "data" / "op.csv")


# ---------------------------------------------------------------- one machine: the task
def process_machine(machine: str) -> dict:
    """Drift check, refit where needed, fresh FMU for one machine folder; the row of the
    summary table. Deterministic in its inputs, so safe to rerun."""
    d = pathlib.Path(machine)
    t0 = time.perf_counter()
    twin = mtwin.load(d / "twin.json")
    new = twin.refit(sorted((d / "data").glob("*.csv")))
    out = d / "out"
    out.mkdir(exist_ok=True)
    # each file atomic (the library writes a temporary file and renames it)
    new.export_fmu(out / "twin.fmu")
    new.save(out / "twin.json")
    rep = new.report or {}
    m1 = (rep.get("modes") or [{}])[0]
    return {
        "machine": d.name,
        "drift_fit_pct": rep.get("drift_fit_pct"),
        "updated": bool(rep.get("updated")),
        "fit_after_pct": rep.get("fit_after_pct") if rep.get("updated") else None,
        "mode1_before_hz": m1.get("freq_before_hz"),
        "mode1_after_hz": m1.get("freq_after_hz"),
        "history": len(new.history),
        "warnings": list(rep.get("warnings") or []),
        "guid": new.guid,
        "seconds": time.perf_counter() - t0,
        "pid": os.getpid(),
    }


def machines_of(fleet: pathlib.Path) -> list:
    return sorted(str(p) for p in fleet.iterdir() if (p / "twin.json").is_file())


# ---------------------------------------------------------------- running the fleet
def run_serial(fleet: pathlib.Path) -> list:
    return [process_machine(m) for m in machines_of(fleet)]


def run_dask(fleet: pathlib.Path, client, kill: bool = False) -> tuple:
    """Every machine as a Dask task on `client`'s cluster; with `kill`, the worker busy
    with a task is killed (SIGKILL) once the first result is in. Returns the rows and
    what was killed."""
    from dask.distributed import as_completed

    machines = machines_of(fleet)
    futures = client.map(process_machine, machines, pure=False)
    killed = None
    rows = {}
    for fut in as_completed(futures):
        row = fut.result()
        rows[row["machine"]] = row
        if kill and killed is None:
            busy = [w for w, keys in client.processing().items() if keys]
            if busy:
                pid = client.run(os.getpid, workers=[busy[0]])[busy[0]]
                os.kill(pid, signal.SIGKILL)
                killed = {"worker": busy[0], "pid": pid, "after_results": len(rows)}
    return [rows[pathlib.Path(m).name] for m in machines], killed


def local_client(workers: int):
    from dask.distributed import Client, LocalCluster

    cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None)
    return Client(cluster)


def check_outputs(fleet: pathlib.Path) -> int:
    """Every machine has a complete twin and FMU (no half-written file): the twin loads, the
    FMU is a whole zip with its model description; returns the machines checked."""
    n = 0
    for m in machines_of(fleet):
        out = pathlib.Path(m) / "out"
        twin = mtwin.load(out / "twin.json")
        with zipfile.ZipFile(out / "twin.fmu") as z:
            assert z.testzip() is None and twin.guid in z.read("modelDescription.xml").decode()
        n += 1
    return n


def table(rows: list) -> str:
    def f(v, fmt="{:.2f}"):
        return "-" if v is None else fmt.format(v) if isinstance(v, float) else str(v)

    head = f"{'machine':<12} {'drift fit %':>11} {'refit':>5} {'fit after %':>11} {'mode 1 Hz':>17} {'hist':>4}  guid"
    lines = [head, "-" * len(head)]
    for r in rows:
        mode = "-" if r["mode1_before_hz"] is None else f"{r['mode1_before_hz']:.1f}->{r['mode1_after_hz']:.1f}"
        lines.append(f"{r['machine']:<12} {f(r['drift_fit_pct']):>11} {('yes' if r['updated'] else 'no'):>5} "
                     f"{f(r['fit_after_pct']):>11} {mode:>17} {r['history']:>4}  {r['guid']}")
    # what the refit said the user must know (an incomplete update), once per machine
    for r in rows:
        for w in r.get("warnings") or []:
            lines.append(f"{r['machine']}: {w}")
    return "\n".join(lines)


def same(a: list, b: list) -> bool:
    return [{k: r[k] for k in COLUMNS} for r in a] == [{k: r[k] for k in COLUMNS} for r in b]


def clear_outputs(fleet: pathlib.Path) -> None:
    for m in machines_of(fleet):
        shutil.rmtree(pathlib.Path(m) / "out", ignore_errors=True)


def bench(machines: int, workers: int, kill: bool, keep: pathlib.Path = None, scheduler: str = None,
          base: pathlib.Path = None) -> dict:
    """Generates a fleet of `machines` copies of `base` (default: :func:`base_twin`), runs
    it serially and on Dask (`workers` local workers, or the cluster at `scheduler`),
    checks results and outputs; the numbers of both runs."""
    work = pathlib.Path(tempfile.mkdtemp(prefix="mtwin-fleet-")) if keep is None else keep
    base = base or base_twin(work / "base")
    fleet = work / "fleet"
    t0 = time.perf_counter()
    generate(fleet, base, machines)
    t_gen = time.perf_counter() - t0
    t0 = time.perf_counter()
    serial = run_serial(fleet)
    t_serial = time.perf_counter() - t0
    clear_outputs(fleet)
    client = local_client(workers) if scheduler is None else __import__("dask.distributed").distributed.Client(scheduler)
    try:
        client.submit(os.getpid, pure=False).result()  # the cluster is up
        t0 = time.perf_counter()
        dist, killed = run_dask(fleet, client, kill=kill)
        t_dist = time.perf_counter() - t0
    finally:
        client.close()
        if scheduler is None:
            client.cluster.close() if getattr(client, "cluster", None) else None
    checked = check_outputs(fleet)
    res = {
        "machines": machines,
        "workers": workers,
        "generate_s": t_gen,
        "serial_s": t_serial,
        "dask_s": t_dist,
        "serial_per_min": 60 * machines / t_serial,
        "dask_per_min": 60 * machines / t_dist,
        "equal": same(serial, dist),
        "killed": killed,
        "outputs_checked": checked,
        "updated": sum(r["updated"] for r in dist),
        "rows": dist,
    }
    if keep is None:
        shutil.rmtree(work, ignore_errors=True)
    return res


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)
    g = sub.add_parser("generate")
    g.add_argument("fleet", type=pathlib.Path)
    g.add_argument("--machines", type=int, default=50)
    g.add_argument("--base", type=pathlib.Path)
    r = sub.add_parser("run")
    r.add_argument("fleet", type=pathlib.Path)
    r.add_argument("--workers", type=int, default=2)
    r.add_argument("--scheduler", help="address of a running Dask scheduler (default: a LocalCluster)")
    r.add_argument("--serial", action="store_true", help="no Dask: one machine after the other")
    b = sub.add_parser("bench")
    b.add_argument("--machines", type=int, default=50)
    b.add_argument("--workers", type=int, default=2)
    b.add_argument("--scheduler")
    b.add_argument("--kill", action="store_true", help="kill a busy worker after the first result")
    a = ap.parse_args(argv)
    if a.cmd == "generate":
        base = a.base or base_twin(pathlib.Path(tempfile.mkdtemp(prefix="mtwin-base-")))
        generate(a.fleet, base, a.machines)
        print(f"{a.machines} machines -> {a.fleet}")
    elif a.cmd == "run":
        t0 = time.perf_counter()
        if a.serial:
            rows = run_serial(a.fleet)
        else:
            from dask.distributed import Client

            client = Client(a.scheduler) if a.scheduler else local_client(a.workers)
            rows, _ = run_dask(a.fleet, client)
            client.close()
        dt = time.perf_counter() - t0
        print(table(rows))
        print(f"{len(rows)} machines in {dt:.1f} s ({60 * len(rows) / dt:.1f} machines/min); "
              f"{sum(r['updated'] for r in rows)} refitted; outputs checked: {check_outputs(a.fleet)}")
    else:
        res = bench(a.machines, a.workers, a.kill, scheduler=a.scheduler)
        print(table(res["rows"]))
        print(f"\n{res['machines']} machines ({res['updated']} refitted), generated in {res['generate_s']:.1f} s")
        print(f"serial:        {res['serial_s']:.1f} s = {res['serial_per_min']:.1f} machines/min")
        print(f"dask, {res['workers']} workers: {res['dask_s']:.1f} s = {res['dask_per_min']:.1f} machines/min"
              + (f" (worker pid {res['killed']['pid']} killed after {res['killed']['after_results']} results)"
                 if res["killed"] else ""))
        print(f"results equal to the serial run: {res['equal']}; complete twins and FMUs: "
              f"{res['outputs_checked']}/{res['machines']}")
        return 0 if res["equal"] and res["outputs_checked"] == res["machines"] else 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
