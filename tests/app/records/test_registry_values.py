"""What the registry accepts as text (app.records.registry.values.checked_text), the same
on SQLite and PostgreSQL; the metrics as stored and read back."""

from __future__ import annotations

import gc
import math

import pytest
from hypothesis import given, strategies as st

from app.errors import InvalidRecordError, PatientNotFound
from app.records.datadir import DataDir
from app.records.registry import Registry
from app.records.registry.values import checked_text, metrics_json, parse_metrics
from core.trial import TrialParameters


@pytest.mark.parametrize("text", ["Ada\0", "\0", "Ad\0a Lovelace"])
def test_a_nul_character_is_refused_in_one_line_naming_the_field(text):
    with pytest.raises(InvalidRecordError) as refused:
        checked_text("therapist", text, 100)
    message = str(refused.value)
    assert message.startswith("therapist holds a NUL character")
    assert "type it again without it" in message
    assert "\n" not in message
    assert "\0" not in message


def test_sqlite_registry_refuses_a_nul_it_could_store(tmp_path):
    """SQLite would keep the NUL; the registry refuses it there too, so a record stays
    storable on the server."""
    registry = Registry(DataDir(tmp_path / "data"))
    with pytest.raises(InvalidRecordError, match="first_name holds a NUL character"):
        registry.create_patient("Ada\0", "Lovelace")
    patient = registry.create_patient("Ada", "Lovelace")
    with pytest.raises(InvalidRecordError, match="notes holds a NUL character"):
        registry.open_session(patient.code, notes="came\0late")



metric_values = st.one_of(st.floats(allow_nan=True, allow_infinity=True, width=64),
                          st.integers(-(2**53), 2**53))


@given(st.lists(st.dictionaries(st.from_regex(r"[a-z][a-z0-9_]{0,20}", fullmatch=True),
                                metric_values, max_size=8), max_size=5))
def test_stored_metrics_read_back_as_floats_with_nan_where_undefined(trials):
    """metrics_json then parse_metrics (the progress query's reader, orjson) gives each
    metric back as stored: finite values equal, NaN and the infinities (stored as null)
    NaN."""
    back = parse_metrics(metrics_json(m) for m in trials)
    assert len(back) == len(trials)
    for stored, read in zip(trials, back, strict=True):
        assert read.keys() == stored.keys()
        for name, value in stored.items():
            if math.isfinite(value):
                assert read[name] == float(value)
            else:
                assert math.isnan(read[name])


@pytest.mark.parametrize("collecting", [True, False])
def test_the_progress_query_leaves_the_garbage_collector_as_it_found_it(tmp_path, collecting):
    """trial_summaries pauses the collector while it builds the rows (its p99 was a full
    collection, bench/stations.py) and leaves it enabled or disabled as it was, also when
    the query fails."""
    registry = Registry(DataDir(tmp_path / "data"))
    code = registry.create_patient("Ada", "Lovelace").code
    trial = registry.begin_trial(code, TrialParameters(), backend="simulator")
    registry.finish_trial(trial.trial_id, "complete", {"rmse_x_m": 0.01, "sparc": math.nan})
    was = gc.isenabled()
    try:
        (gc.enable if collecting else gc.disable)()
        (summary,) = registry.trial_summaries(code)
        assert gc.isenabled() is collecting
        assert summary.metrics["rmse_x_m"] == 0.01
        assert math.isnan(summary.metrics["sparc"])
        with pytest.raises(PatientNotFound):
            registry.trial_summaries("ZZZZZZ")
        assert gc.isenabled() is collecting
    finally:
        (gc.enable if was else gc.disable)()
