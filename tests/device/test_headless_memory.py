"""A headless trial holds a block's worth of its reference and of its sensor noise, not the
whole trial's (issue 13 #21: a 100 × 120 s trial's reference alone was 6 million rows), and
the rows it loads a block at a time are the very rows the whole table had."""

import itertools

import numpy as np
import pytest

from core.trial import THESIS_SUBJECT
from device.loop import engine
from device.loop.engine import run_trial
from device.loop.pipeline import TickPipeline, TrialPlan
from device.safety.supervisor import SafetySupervisor
from device.sim.simulator import NOISE_BLOCK, SimulatorBackend

BLOCK = 300


def headless(params, *, compiled=True, patient="healthy"):
    """A whole trial as app.trials.headless runs it, kept in memory; and its pipeline."""
    plan = TrialPlan.build(params)
    backend = SimulatorBackend.from_trial(params, patient, seed=2, robot=plan.robot,
                                          compiled=compiled, plant="realistic")
    pipeline = TickPipeline(plan, compiled=compiled)
    outcome = run_trial(backend, pipeline, SafetySupervisor(plan.robot))
    return outcome, pipeline, backend


@pytest.fixture
def watched(monkeypatch):
    """The most reference rows and noise rows a run held at once."""
    held = {"rows": 0, "noise": 0}
    make_table = TickPipeline._table
    top_up = SimulatorBackend.top_up_noise

    def table(self, rows):
        held["rows"] = max(held["rows"], len(rows))
        return make_table(self, rows)

    def noise(self, rows):
        top_up(self, rows)
        held["noise"] = max(held["noise"], len(self.noise))

    monkeypatch.setattr(TickPipeline, "_table", table)
    monkeypatch.setattr(SimulatorBackend, "top_up_noise", noise)
    return held


@pytest.mark.parametrize("assist", ["thesis", "as-needed"])
def test_the_reference_and_the_noise_held_do_not_grow_with_the_repetitions(
        monkeypatch, watched, assist):
    monkeypatch.setattr(engine, "BLOCK_TICKS", BLOCK)
    held = []
    for repetitions in (1, 4):
        watched.update(rows=0, noise=0)
        outcome, pipeline, _ = headless(THESIS_SUBJECT.replace(repetitions=repetitions,
                                                               assist=assist))
        assert outcome.status == "complete"
        assert pipeline.total_ticks > 4 * BLOCK  # the trial spans many blocks
        held.append(dict(watched))
    # a block's rows, what the guidance may search around it and the rows behind
    bound = BLOCK + engine.ROWS_BEHIND + 500
    assert held[0]["rows"] <= bound
    assert held[1]["rows"] <= bound
    assert held[1]["noise"] <= 2 * max(NOISE_BLOCK, BLOCK + 1)


@pytest.mark.parametrize(("assist", "patient", "compiled"), [
    ("thesis", "healthy", True), ("as-needed", "wrong_way", True),
    ("as-needed", "weak", False)])
def test_rows_loaded_a_block_at_a_time_give_the_whole_tables_trial_bit_for_bit(
        monkeypatch, assist, patient, compiled):
    """The same trial with its reference loaded 257 rows at a time (the as-needed guidance
    asking for rows behind and ahead of the clock) and in one piece: every record equal."""
    params = THESIS_SUBJECT.replace(repetitions=2, assist=assist,
                                    duration_s=THESIS_SUBJECT.duration_s if compiled else 3.0)
    whole, pipeline, _ = headless(params, compiled=compiled, patient=patient)
    assert pipeline.loaded_rows >= pipeline.n_rows - engine.ROWS_BEHIND
    monkeypatch.setattr(engine, "BLOCK_TICKS", 257)
    loads = []
    load_rows = TickPipeline.load_rows

    def counted(self, first, stop):
        loads.append(stop - first)
        load_rows(self, first, stop)

    monkeypatch.setattr(TickPipeline, "load_rows", counted)
    blocks, pipeline, _ = headless(params, compiled=compiled, patient=patient)
    assert len(loads) > pipeline.n_rows // 1000
    assert whole.status == blocks.status == "complete"
    for name in whole.records.dtype.names:
        np.testing.assert_array_equal(blocks.records[name], whole.records[name], err_msg=name)


def test_any_stretch_of_the_reference_is_the_whole_tables_rows():
    """TrialPlan.reference computes each row from its tick alone: stretches cut anywhere
    put together are the table computed in one piece, bit for bit."""
    plan = TrialPlan.build(THESIS_SUBJECT.replace(repetitions=3, timing="minimum_jerk"))
    n = plan.exercise_ticks
    whole = plan.reference(0, n)
    assert whole.shape == (n, 12)
    cuts = np.sort(np.random.default_rng(1).choice(np.arange(1, n), 30, replace=False))
    bounds = [0, *cuts.tolist(), n]
    pieces = np.vstack([plan.reference(a, b) for a, b in itertools.pairwise(bounds)])
    np.testing.assert_array_equal(pieces, whole)
    assert plan.start_point_m == (whole[0, 0], whole[0, 1])
    # the live loop's plan computes it all at Build: the same rows
    tabulated = TrialPlan.build(plan.parameters, tabulated=True)
    np.testing.assert_array_equal(tabulated.table, whole)
    np.testing.assert_array_equal(tabulated.reference(17, 4000), whole[17:4000])
    assert len(plan.reference(n - 5, n + 10)) == 5  # clipped to the exercise
