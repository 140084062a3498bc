"""The fleet example on Dask (examples/python/fleet_dask.py): 50 generated machines on a
LocalCluster of 2 workers, one worker killed (SIGKILL) while busy. Its tasks rerun, the
results equal a serial run, every machine has a complete twin and FMU. The throughput
table is `fleet_dask.py bench --machines 50 --kill` (README)."""
import pytest

pytest.importorskip("mtwin", reason="the package is not installed: scripts/build-wheel.sh --install")
pytest.importorskip("dask.distributed")

import fleet_dask  # noqa: E402  (examples/python is on sys.path, conftest.py)


def test_fleet_on_two_workers_with_one_killed(pkg, tmp_path):
    base = tmp_path / "base.json"
    pkg["twin"].save(base)
    n = 50
    res = fleet_dask.bench(n, 2, kill=True, keep=tmp_path / "work", base=base)
    assert res["killed"] is not None
    assert res["equal"], fleet_dask.table(res["rows"])
    assert res["outputs_checked"] == n
    assert res["updated"] == len(range(0, n, 3))  # the worn machines (every third), not the others
    assert all(r["history"] == (2 if r["updated"] else 1) for r in res["rows"])
