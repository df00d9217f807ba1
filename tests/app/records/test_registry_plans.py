"""Plans in the registry (schema v7, app.records.registry.plans): saved per patient, changed
for the day as a new plan, each run's trials and rests in order; sealed like every row."""

import sqlite3

import pytest

from app.errors import InvalidRecordError, RegistryError
from app.plans.templates import load_template
from app.records.datadir import DataDir
from app.records.registry import Registry
from core.plan import Block
from core.trial import THESIS_SUBJECT


@pytest.fixture
def registry(open_registry):
    """The registry on each engine in turn (tests/app/records/conftest.py)."""
    return open_registry()


def patient(registry, first="Ada"):
    return registry.create_patient(first, "Example", body_mass_kg=70.0, upper_arm_m=0.3,
                                   forearm_m=0.28, side="right", shoulder_m=(-0.12, 0.73)).code


def test_a_template_copied_to_a_patient_and_changed_for_today_keeps_both(registry):
    code = patient(registry)
    template = load_template("first-session")
    first = registry.save_plan(code, template.plan, template="first-session")
    assert registry.current_plan(code) == first
    assert first.plan == template.plan
    assert first.based_on is None
    slower = first.plan.blocks[1].replace(duration_s=7.0, rest_s=30.0)
    today = registry.change_block(first.id, 1, slower)
    assert today.based_on == first.id
    assert today.template == "first-session"
    assert today.plan.blocks[1] == slower
    assert today.plan.blocks[0] == first.plan.blocks[0]
    assert registry.plan(first.id) == first  # the plan changed from is kept as it was
    assert registry.current_plan(code) == today
    assert [p.id for p in registry.plans_for_patient(code)] == [first.id, today.id]
    with pytest.raises(InvalidRecordError, match="1–3"):
        registry.change_block(first.id, 3, slower)
    other = patient(registry, "Bo")
    assert registry.current_plan(other) is None
    with pytest.raises(InvalidRecordError, match="not a plan of patient"):
        registry.save_plan(other, first.plan, based_on=first.id)


def test_a_run_keeps_its_trials_and_rests_in_order_and_ends_once(registry):
    code = patient(registry)
    plan = registry.save_plan(code, load_template("first-session").plan)
    run = registry.begin_plan_run(plan.id)
    trial = registry.begin_trial(code, THESIS_SUBJECT, backend="simulator").trial_id
    registry.record_plan_trial(run, 1, 1, trial, 15.0)
    registry.record_plan_rest(run, 1, 60.0, 12.5)
    assert registry.plan_run(run).status == "running"
    with pytest.raises(InvalidRecordError, match="blocks 1–3"):
        registry.record_plan_rest(run, 4, 60.0, 1.0)
    with pytest.raises(InvalidRecordError, match="taken_s"):
        registry.record_plan_rest(run, 2, 60.0, -1.0)
    ended = registry.end_plan_run(run, "stopped", "Stop pressed in the rest after block 1")
    assert ended.status == "stopped"
    assert ended.ended_at is not None
    assert [(s.step, s.block, s.kind, s.trial_id, s.taken_s) for s in ended.steps] == [
        (1, 1, "trial", trial, None), (2, 1, "rest", None, 12.5)]
    assert registry.plan_step_of_trial(trial)[0] == run
    with pytest.raises(RegistryError, match="ended"):
        registry.record_plan_rest(run, 2, 60.0, 1.0)
    with pytest.raises(RegistryError, match="already ended"):
        registry.end_plan_run(run, "complete")
    assert registry.plan_runs_for_patient(code) == [ended]


def test_a_run_a_crashed_console_left_reads_interrupted(registry):
    code = patient(registry)
    plan = registry.save_plan(code, load_template("reaching").plan)
    run = registry.begin_plan_run(plan.id)
    assert registry.interrupt_runs() == [run]
    assert registry.plan_run(run).status == "interrupted"
    assert registry.interrupt_runs() == []


def test_a_withdrawn_trial_leaves_its_run(registry):
    code = patient(registry)
    plan = registry.save_plan(code, load_template("first-session").plan)
    run = registry.begin_plan_run(plan.id)
    trial = registry.begin_trial(code, THESIS_SUBJECT, backend="simulator").trial_id
    registry.record_plan_trial(run, 1, 1, trial, 15.0)
    registry.withdraw_trial(trial, "refused by the loop")
    assert registry.plan_run(run).steps == ()


def test_a_plan_edited_outside_the_console_is_refused(tmp_path):
    """SQLite's file (a server's registry is checked by `rehab db status`: the tests of
    postgres/seals.py)."""
    registry = Registry(DataDir(tmp_path / "data"))
    code = patient(registry)
    registry.save_plan(code, load_template("first-session").plan)
    with sqlite3.connect(registry.path) as conn:
        conn.execute("DROP TRIGGER plans_sealed_on_update")
        conn.execute("UPDATE plans SET plan = replace(plan, '\"rest_s\": 60.0', "
                     "'\"rest_s\": 6.0')")
    with pytest.raises(RegistryError, match="plans row 1 does not match its seal"):
        Registry(registry.data_dir).current_plan(code)


def test_a_plan_this_console_cannot_run_is_refused_naming_it(registry):
    code = patient(registry)
    saved = registry.save_plan(code, load_template("first-session").plan)
    # written by the console's own connection (sealed), as a newer console might
    with registry._write() as conn:
        conn.exec_driver_sql("UPDATE plans SET plan = replace(plan, '\"shape\": \"circle\"', "
                             "'\"shape\": \"spiral\"')")
    with pytest.raises(InvalidRecordError, match=f"plan {saved.id} .* block 2.shape"):
        registry.plan(saved.id)


def test_a_block_of_another_kind_is_refused(registry):
    code = patient(registry)
    with pytest.raises(InvalidRecordError, match=r"core\.plan\.Plan"):
        registry.save_plan(code, {"name": "x", "blocks": []})
    assert Block().rest_s == 60.0
