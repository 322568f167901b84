"""A study gives byte-identical cases.csv in this process, on a process pool and on a Dask
cluster (a LocalCluster of two worker processes on loopback): a case is a pure function of
its content, and a warm-started chain passes its optimum along exactly."""
from __future__ import annotations

from pathlib import Path

import pytest

import optdesign
from optdesign.study import Study, grid, values

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def study():
    scene = optdesign.load(ROOT / "problems" / "seed1_jib_design.toml")
    # two chains of two warm-started cases, and the jib length changes the optimum
    return Study(scene, [values("l", [3.6, 4.4]), grid("mC", 400, 600, 2)], starts=2)


@pytest.fixture(scope="module")
def serial(study, tmp_path_factory):
    folder = tmp_path_factory.mktemp("serial")
    result = study.run(out=folder, workers=1, figures=False)
    assert result.complete and all(r["success"] for r in result.rows)
    assert [r["warm"] for r in result.rows] == [False, True, False, True]
    return (folder / "cases.csv").read_bytes()


def test_process_pool_matches_serial(study, serial, tmp_path):
    result = study.run(out=tmp_path, workers=2, figures=False)
    assert result.computed == 4
    assert (tmp_path / "cases.csv").read_bytes() == serial


def test_dask_local_cluster_matches_serial(study, serial, tmp_path):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address=None) as cluster:
        result = study.run(out=tmp_path, scheduler=cluster.scheduler_address, figures=False)
    assert result.computed == 4
    assert "Dask cluster at tcp://127.0.0.1" in (tmp_path / "summary.txt").read_text()
    assert (tmp_path / "cases.csv").read_bytes() == serial


def test_cli_scheduler_at_a_bad_address_is_an_error(tmp_path, capsys):
    dask = pytest.importorskip("dask")
    from optdesign.cli.main import main

    with dask.config.set({"distributed.comm.timeouts.connect": "2s"}):
        code = main(["study", str(ROOT / "problems" / "seed1_jib.toml"), "--mode", "analyse", "--values", "mC=400,500",
                     "--scheduler", "tcp://127.0.0.1:9", "--out", str(tmp_path)])
    assert code == 2
    assert "cannot reach the Dask scheduler" in capsys.readouterr().err
