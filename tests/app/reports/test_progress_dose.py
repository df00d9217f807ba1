"""The session plans' dose in the progress report (issue 30: 'the Progress tab and the
session report show it'): each plan run's movements, active time and rest per block against
the plan, counted from its trial files, on a page of the progress PDF after the exercises,
written by `rehab progress CODE --pdf` and the Progress tab alike."""

from __future__ import annotations

import dataclasses

import pytest

from app.plans.dose import patient_doses, run_dose
from app.plans.templates import load_template
from app.records.datadir import DataDir
from app.records.registry import Registry
from app.reports.progress import progress
from app.reports.progress_pdf import progress_pages, write_progress_pdf
from core.trial import TrialParameters
from tests.app.reports.made import page_texts, register


@pytest.fixture
def ran(tmp_path):
    """A first-session plan run stopped in its second block: block 1's one lap ran (a
    simulated trial file), its rest was taken, the run stopped."""
    registry = Registry(DataDir(tmp_path / "data"))
    code = registry.create_patient("Ada", "Example", body_mass_kg=91.0, upper_arm_m=0.3048,
                                   forearm_m=0.3048, side="right",
                                   shoulder_m=(-0.12, 0.73)).code
    plan = load_template("first-session").plan
    short = tuple(b.replace(repetitions=1, duration_s=3.0, rest_s=2.0) for b in plan.blocks)
    plan = dataclasses.replace(plan, blocks=short)
    stored = registry.save_plan(code, plan, template="first-session")
    run = registry.begin_plan_run(stored.id)
    parameters = plan.blocks[0].parameters(
        TrialParameters().replace(**registry.patient(code).trial_overrides()))
    trial_id = register(registry, code, parameters, session=1, patient="healthy")
    registry.record_plan_trial(run, 1, 1, trial_id, 3.0)
    registry.record_plan_rest(run, 1, 2.0, 2.0)
    registry.end_plan_run(run, "stopped", "the therapist pressed Stop")
    return registry, code, run


def test_the_progress_pdf_ends_with_each_plan_run_s_dose(ran, tmp_path):
    registry, code, run = ran
    dose = run_dose(registry, run)
    assert dose.movements == 1  # the D's one lap
    assert dose.planned_movements == 4  # 1 + 1 + a reach out and back
    doses = patient_doses(registry, code)
    assert [d.run_id for _, d in doses] == [run]
    assert "stopped" in doses[0][0]
    pdf = write_progress_pdf(progress(registry, code), tmp_path / "progress.pdf",
                             doses=doses)
    last = page_texts(pdf)[-1]
    assert f"Session plans of {code}: the dose" in last
    assert f"run {run}): stopped" in last
    for line in dose.table():  # the same figures as `rehab plan dose`
        assert " ".join(line.split()) in last


def test_without_a_plan_run_there_is_no_dose_page(ran):
    registry, code, _ = ran
    result = progress(registry, code)
    assert len(progress_pages(result, ())) == len(progress_pages(result)) \
        == len(progress_pages(result, patient_doses(registry, code))) - 1
