"""A plan run's event (app.plans.record): a note with its time on the session the run's
trials are in, naming the run and the block; refused in one line before the run has a
trial (no session to note it on)."""

import pytest

from app.errors import RegistryError
from app.plans.record import AUTHOR, record_plan_event
from app.plans.templates import load_template
from app.records.datadir import DataDir
from app.records.registry import Registry
from core.trial import THESIS_SUBJECT


def test_a_plan_s_pause_is_noted_on_its_session_with_its_time(tmp_path):
    registry = Registry(DataDir(tmp_path / "data"))
    code = registry.create_patient("Ada", "Example", body_mass_kg=70.0, upper_arm_m=0.3,
                                   forearm_m=0.28, side="right",
                                   shoulder_m=(-0.12, 0.73)).code
    plan = registry.save_plan(code, load_template("first-session").plan)
    run = registry.begin_plan_run(plan.id)
    with pytest.raises(RegistryError, match=f"plan run {run} has no trial yet"):
        record_plan_event(registry, run, 1, "paused: the robot was disconnected")
    trial = registry.begin_trial(code, THESIS_SUBJECT, backend="simulator")
    registry.record_plan_trial(run, 1, 1, trial.trial_id, 15.0)
    note = record_plan_event(registry, run, 1, "paused: the robot was disconnected")
    (kept,) = registry.notes(code)
    assert kept == note
    assert kept.text == f"Plan run {run}, block 1: paused: the robot was disconnected"
    assert kept.author == AUTHOR
    assert kept.session_number == 1
    assert kept.written_at is not None
