"""Study-wide analysis on Dask (issue 32): a generated study analysed on a local cluster of
two worker processes equals the per-trial results computed one by one; a damaged file and
files that are not trials are listed with why while the rest is analysed; Parquet by
patient read back with DuckDB, the CSV and the researcher's Dask dataframe hold the same
rows; the cluster listens on 127.0.0.1 only."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from app.exports.loader import read_info
from app.reports.progress import exercise_of
from app.study import sources
from app.study.outputs import write_study
from app.study.run import analyse_study, chunks, study_frame
from app.study.schema import COLUMNS, METRICS
from app.trials.analysis import analyse
from app.trials.reader import read_trial
from tests.app.study.conftest import PATIENTS, SOUND

METRIC_COLUMNS = [f"metric_{name}" for name in METRICS]


@pytest.fixture(scope="module")
def selection(study):
    return sources.from_folder(study)


@pytest.fixture(scope="module")
def result(selection, client):
    return analyse_study(selection, client)


def test_study_analysis_equals_the_trials_analysed_one_by_one(study, result):
    trials = result.trials
    assert len(trials) == SOUND
    assert result.workers == 2
    for row in trials.to_dict("records"):
        path = study / row["file"]
        data = read_trial(path)  # every channel, as a report reads it
        expected = analyse(data.channels, data.parameters).to_metrics()
        got = {name[len("metric_"):]: row[name] for name in METRIC_COLUMNS
               if not math.isnan(row[name])}
        finite = {k: v for k, v in expected.items() if not math.isnan(v)}
        assert got == finite, path.name  # exactly: the same code on the same samples
        # ... and what the console stored in the file when it finalized the trial
        np.testing.assert_equal({k: row[f"metric_{k}"] for k in data.metrics}, data.metrics)
        info = read_info(path).row(study)
        for key, value in info.items():
            if key.startswith("metric_") or key not in COLUMNS:
                continue
            assert row[key] == value or (value is None and pd.isna(row[key])), key
        values = dict(read_info(path).parameter_values)
        assert row["exercise"] == exercise_of(values["assist"], values).label()
        assert row["patient"] == path.parent.name == data.subject.code
        assert row["site"] == PATIENTS[row["patient"]]
        assert row["failure"] == ""
    # each patient's rows in the order of their progress: session, then trial
    order = trials[["patient", "session", "trial"]].to_records(index=False).tolist()
    assert order == sorted(order)


def test_damaged_and_foreign_files_are_listed_with_why_and_the_rest_is_analysed(result):
    reasons = dict(zip(result.failures["file"], result.failures["reason"], strict=True))
    assert set(reasons) == {"truncated.h5", "other.h5", "notes.h5"}
    assert "not a rehab-console trial file" in reasons["other.h5"]
    assert "not an HDF5 file" in reasons["notes.h5"]
    assert "truncated.h5" in reasons["truncated.h5"]
    for reason in reasons.values():
        assert "\n" not in reason
        assert "restore" in reason.lower() or "choose" in reason.lower()  # what to do
    assert len(result.trials) == SOUND


def test_parquet_by_patient_read_back_with_duckdb_and_the_csv_give_the_same_rows(
        result, tmp_path):
    import duckdb

    dataset, trials_csv, failures_csv = write_study(result, tmp_path / "out")
    assert sorted(p.name for p in dataset.iterdir()) == [f"patient={c}" for c in
                                                         sorted(PATIENTS)]
    columns = ["patient", "site", "session", "trial", "file", "exercise", "status",
               *METRIC_COLUMNS]
    picked = ", ".join(columns)
    back = duckdb.sql(f"SELECT {picked} FROM read_parquet('{dataset}/*/*.parquet', "
                      "hive_partitioning = true) ORDER BY file").df()
    expected = result.trials.sort_values("file")[columns].reset_index(drop=True)
    for name in columns:
        left, right = back[name].to_numpy(), expected[name].to_numpy()
        if name.startswith("metric_"):
            np.testing.assert_array_equal(left.astype(float), right.astype(float))
        else:
            assert [str(v) for v in left] == [str(v) for v in right], name
    csv = duckdb.sql(f"SELECT file, metric_sparc, metric_rmse_x_m FROM "
                     f"read_csv('{trials_csv}') ORDER BY file").df()
    np.testing.assert_array_equal(csv["metric_sparc"], expected["metric_sparc"])
    assert list(csv["file"]) == list(expected["file"])
    failed = duckdb.sql(f"SELECT file FROM read_csv('{failures_csv}') ORDER BY file").df()
    assert list(failed["file"]) == ["notes.h5", "other.h5", "truncated.h5"]


def test_the_python_api_is_a_dask_dataframe_of_the_same_rows(selection, result, client):
    import dask.dataframe as dd

    frame = study_frame(selection)
    assert isinstance(frame, dd.DataFrame)
    assert list(frame.columns) == list(COLUMNS)
    assert frame.npartitions == len(chunks(selection.trials))
    # lazily, as a researcher asks; computed with the whole frame, from the same partitions
    means = frame[frame.failure == ""].groupby("patient").metric_sparc.mean()
    computed, means = (future.result() for future in client.compute([frame, means]))
    trials = computed[computed["failure"] == ""].sort_values("file").reset_index(drop=True)
    expected = result.trials.sort_values("file").reset_index(drop=True)
    pd.testing.assert_frame_equal(trials, expected)
    assert sorted(computed.loc[computed["failure"] != "", "file"]) == sorted(
        result.failures["file"])
    np.testing.assert_allclose(
        means.sort_index().to_numpy(),
        expected.groupby("patient").metric_sparc.mean().sort_index().to_numpy())


def test_the_local_cluster_listens_on_127_0_0_1_only_and_has_no_dashboard(client):
    # the workers as they register, not as the scheduler knew them at one moment: a loaded
    # host had them unregistered (0 workers) when the whole check asked (a bound, not a
    # timing)
    client.wait_for_workers(2, timeout=120)
    info = client.scheduler_info(n_workers=-1)
    addresses = [client.scheduler.address, *info["workers"],
                 *(w["nanny"] for w in info["workers"].values())]
    assert len(info["workers"]) == 2
    assert all(a.startswith("tcp://127.0.0.1:") for a in addresses), addresses
    assert all(w["nthreads"] == 1 for w in info["workers"].values())

    def http_hosts(dask_scheduler=None, dask_worker=None):
        server = (dask_scheduler or dask_worker).http_server
        return sorted({s.getsockname()[0] for s in server._sockets.values()})

    assert client.run_on_scheduler(http_hosts) == ["127.0.0.1"]
    assert set(map(tuple, client.run(http_hosts).values())) == {("127.0.0.1",)}
    # the dashboard (bokeh's pages) is not served: only the health check
    assert not client.run_on_scheduler(
        lambda dask_scheduler: "bokeh" in dask_scheduler.services)
    pids = client.run(lambda: __import__("os").getpid())
    assert len(set(pids.values())) == 2  # two processes: h5py is never shared by threads


def test_a_slow_worker_killed_at_the_end_is_not_said_as_a_warning(client, caplog):
    """On a busy machine Dask kills a local worker that takes over 4 s to exit once the
    study is done, and its nanny logged that as a warning, which `rehab study analyse`
    printed after a study that succeeded. Other warnings still come through."""
    import logging

    nanny = logging.getLogger("distributed.nanny")
    with caplog.at_level(logging.WARNING):
        nanny.warning("Worker process still alive after 4.0 seconds, killing")
        nanny.warning("something else")
    said = [r.getMessage() for r in caplog.records]
    assert "something else" in said
    assert not any(m.startswith("Worker process still alive") for m in said)


def test_chunks_keep_every_worker_busy_and_tasks_few():
    trials = list(range(10_000))
    parts = chunks(trials, 2)
    assert [t for part in parts for t in part] == trials
    assert max(map(len, parts)) == 50
    assert [len(p) for p in chunks(trials[:9], 2)] == [1] * 9


def test_a_second_cluster_that_stops_leaves_the_firsts_quiet_shutdown(client, caplog):
    """One filter object was shared by every local cluster: a study run (`rehab study
    analyse` in-process) while another cluster was open took it away as it stopped, and the
    first cluster's slow workers were said as warnings again (seen in a fresh-clone check)."""
    import logging

    from app.study.cluster import study_client

    with study_client(workers=1):
        pass
    nanny = logging.getLogger("distributed.nanny")
    with caplog.at_level(logging.WARNING):
        nanny.warning("Worker process still alive after 4.0 seconds, killing")
    assert not any(r.getMessage().startswith("Worker process still alive")
                   for r in caplog.records)
