"""The fleet example on Dask (examples/python/fleet_dask.py), small: 6 machines on a
LocalCluster of 2 workers, one worker killed (SIGKILL) while busy. Its tasks rerun, the
results equal a serial run, every machine has a complete twin and FMU. The 50-machine run
with throughput is `fleet_dask.py bench --machines 50 --kill` (README)."""
import pytest

pytest.importorskip("mtwin", reason="the package is not installed: scripts/build-wheel.sh --install")
pytest.importorskip("dask.distributed")

import fleet_dask  # noqa: E402  (examples/python is on sys.path, conftest.py)


def test_fleet_on_two_workers_with_one_killed(pkg, tmp_path):
    base = tmp_path / "base.json"
    pkg["twin"].save(base)
    res = fleet_dask.bench(6, 2, kill=True, keep=tmp_path / "work", base=base)
    assert res["killed"] is not None
    assert res["equal"], fleet_dask.table(res["rows"])
    assert res["outputs_checked"] == 6
    assert res["updated"] == 2  # the worn machines (every third), not the others
    assert all(r["history"] == (2 if r["updated"] else 1) for r in res["rows"])
