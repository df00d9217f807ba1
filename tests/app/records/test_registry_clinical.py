"""Schema v8 (issue 31): sex and handedness, clinical scales per session, notes, trials
marked invalid, corrections with an audit trail; the migration from v7 keeps every record
and refuses a row damaged before it."""

from __future__ import annotations

import contextlib
import datetime
import json
import sqlite3

import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from app.errors import InvalidRecordError, RegistryError, SchemaError, SessionNotFound
from app.records.datadir import DataDir
from app.records.registry import SCHEMA_VERSION, Registration, Registry, seals
from app.records.scales import (
    ARAT_SUBSCALES,
    ASHWORTH_GRADES,
    FUGL_MEYER_ITEMS,
    FUGL_MEYER_PARTS,
    SCALE_MAXIMA,
    SCALES,
    score,
)
from core.trial import THESIS_SUBJECT, TrialParameters
from tests.app.records.history import registry_at

V7_TABLES = ("patients", "sessions", "trials", "proposals", "plans", "plan_runs",
             "plan_steps")


def make_v7_registry(folder) -> None:
    """A registry as the console left it at schema v7: two patients, a session each, a
    finished trial with its pending proposal, a plan and a run of it."""
    with registry_at(folder, 7) as conn:
        conn.execute("INSERT INTO patients (code, first_name, last_name, birth_year, side, "
                     "body_mass_kg, upper_arm_m, forearm_m, shoulder_x_m, shoulder_y_m, notes, "
                     "created_at) VALUES ('PABC234', 'Ada', 'Example', 1950, 'left', 71.5, "
                     "0.31, 0.27, -0.12, 0.73, 'since 2026', '2026-11-05T10:00:00+00:00')")
        conn.execute("INSERT INTO patients (code, created_at) VALUES ('PXYZ789', "
                     "'2026-11-06T10:00:00+00:00')")
        conn.execute("INSERT INTO sessions (patient_id, number, date, therapist, location) "
                     "VALUES (1, 1, '2026-11-05', 'K. Lee', 'room 2')")
        conn.execute("INSERT INTO sessions (patient_id, number, date) VALUES (2, 1, "
                     "'2026-11-06')")
        conn.execute(
            "INSERT INTO trials (session_id, number, parameters, file, metrics, status, "
            "started_at, ended_at, backend, end_reason) VALUES (1, 1, ?, "
            "'trials/PABC234/t1.h5', ?, 'complete', '2026-11-05T10:05:00+00:00', "
            "'2026-11-05T10:05:40+00:00', 'simulator', '')",
            (json.dumps(THESIS_SUBJECT.to_dict()), json.dumps({"rmse_x_m": 0.008})))
        conn.execute("INSERT INTO proposals (trial_id, proposal, proposed_at) VALUES "
                     "(1, '{\"reason\": \"same\"}', '2026-11-05T10:05:41+00:00')")
        conn.execute("INSERT INTO plans (patient_id, name, plan, created_at) VALUES "
                     "(1, 'daily', '{}', '2026-11-05T10:00:00+00:00')")
        conn.execute("INSERT INTO plan_runs (plan_id, started_at, status) VALUES "
                     "(1, '2026-11-05T10:04:00+00:00', 'running')")
        conn.execute("INSERT INTO plan_steps (run_id, step, block, round, kind, trial_id, "
                     "planned_s) VALUES (1, 1, 1, 1, 'trial', 1, 40.0)")


def table_rows(path, table, columns):
    with contextlib.closing(sqlite3.connect(path)) as conn:
        return conn.execute(f"SELECT {', '.join(columns)} FROM {table} ORDER BY rowid"
                            ).fetchall()


def v7_columns(table):
    return seals.sealed_at(table, 7)


def test_a_v7_registry_is_migrated_to_today_keeping_every_record(tmp_path):
    make_v7_registry(tmp_path / "data")
    path = tmp_path / "data" / "registry.sqlite3"
    before = {t: table_rows(path, t, v7_columns(t)) for t in V7_TABLES}

    registry = Registry(DataDir(tmp_path / "data"))

    assert registry.schema_version() == SCHEMA_VERSION == 13
    assert {t: table_rows(path, t, v7_columns(t)) for t in V7_TABLES} == before
    assert list((tmp_path / "data").glob("registry.sqlite3.v7-*.bak"))
    ada = registry.patient("PABC234")
    assert (ada.last_name, ada.birth_year, ada.shoulder_m, ada.sex, ada.handedness) == (
        "Example", 1950, (-0.12, 0.73), None, None)
    (trial,) = registry.trials_for_patient("PABC234")
    assert trial.metrics == {"rmse_x_m": 0.008}
    assert registry.pending_proposal("PABC234").trial_id == 1
    assert registry.integrity_check() == []
    # the patients' rows carry seals over the new columns: the v8 console writes them
    changed = registry.update_patient("PABC234", sex="female", handedness="right")
    assert (changed.sex, changed.handedness) == ("female", "right")
    assert Registry(DataDir(tmp_path / "data")).patient("PABC234").sex == "female"


def test_a_patient_row_damaged_before_the_upgrade_is_refused_not_sealed_again(tmp_path):
    make_v7_registry(tmp_path / "data")
    path = tmp_path / "data" / "registry.sqlite3"
    with contextlib.closing(sqlite3.connect(path, isolation_level=None)) as conn:
        conn.execute("DROP TRIGGER patients_sealed_on_update")  # as a database browser would
        conn.execute("UPDATE patients SET birth_year = 1951 WHERE code = 'PABC234'")
    with pytest.raises(SchemaError, match=r"could not be updated to schema v8 .*"
                                          r"patients_rows_match_their_seals.*still v7"):
        Registry(DataDir(tmp_path / "data"))
    with contextlib.closing(sqlite3.connect(path)) as conn:
        assert conn.execute("PRAGMA user_version").fetchone() == (7,)
        columns = {r[1] for r in conn.execute("PRAGMA table_info(patients)")}
    assert "sex" not in columns


@pytest.fixture
def registry(open_registry):
    """The registry on each engine in turn (tests/app/records/conftest.py)."""
    return open_registry()


def finished_trial(registry, code, session_number=1, metrics=None):
    begun = registry.begin_trial(code, THESIS_SUBJECT, backend="simulator",
                                 session_number=session_number)
    registry.finish_trial(begun.trial_id, "complete", metrics or {"rmse_x_m": 0.01})
    return begun.trial_id


def test_sex_and_handedness_are_kept_and_anything_else_refused(registry):
    patient = registry.create_patient("Ada", "Example", sex="female", handedness="left")
    assert (patient.sex, patient.handedness) == ("female", "left")
    for field, value in (("sex", "f"), ("sex", "other"), ("handedness", "both")):
        with pytest.raises(InvalidRecordError) as caught:
            registry.create_patient("Bo", "Sample", **{field: value})
        assert "\n" not in str(caught.value)
        assert field in str(caught.value)
    assert len(registry.patients()) == 1


# -- scales ------------------------------------------------------------------------------

FM_ITEMS = {item.key: item.maximum for item in FUGL_MEYER_ITEMS}


def test_the_fugl_meyer_items_add_up_to_its_parts_and_66():
    assert len(FUGL_MEYER_ITEMS) == 33
    for part, maximum in FUGL_MEYER_PARTS.items():
        assert sum(i.maximum for i in FUGL_MEYER_ITEMS if i.part == part) == maximum
    full = score("fugl_meyer", items=FM_ITEMS)
    assert full.total == 66 == sum(FUGL_MEYER_PARTS.values())
    assert full.detail["parts"] == FUGL_MEYER_PARTS
    assert sum(ARAT_SUBSCALES.values()) == 57


@settings(max_examples=60, deadline=None)
@given(scale=st.sampled_from(["fugl_meyer", "arat", "pain", "fatigue"]),
       total=st.integers(-100, 200))
def test_a_total_is_kept_in_its_range_and_refused_outside_in_one_line(scale, total):
    if 0 <= total <= SCALE_MAXIMA[scale]:
        assert score(scale, total=total).total == total
    else:
        with pytest.raises(InvalidRecordError) as caught:
            score(scale, total=total)
        text = str(caught.value)
        assert "\n" not in text
        assert f"0-{SCALE_MAXIMA[scale]}" in text


@settings(max_examples=60, deadline=None)
@given(st.fixed_dictionaries({item.key: st.sampled_from(item.scores)
                              for item in FUGL_MEYER_ITEMS}))
def test_the_fugl_meyer_total_is_the_sum_of_its_items(items):
    scored = score("fugl_meyer", items=items)
    assert scored.total == sum(items.values())
    assert sum(scored.detail["parts"].values()) == scored.total


@pytest.mark.parametrize(("given", "words"), [
    ({"items": FM_ITEMS | {"d_time": 3}}, "d_time = 3 is out of range; give a whole number 0-2"),
    ({"items": FM_ITEMS | {"a1_reflex_flexors": 1}}, "not a score it has; give 0 or 2"),
    ({"items": {k: v for k, v in FM_ITEMS.items() if k != "c_mass_flexion"}},
     "c_mass_flexion missing"),
    ({"parts": {"A": 37, "B": 0, "C": 0, "D": 0}}, "Fugl-Meyer UE motor A = 37"),
    ({"parts": {"A": 3, "B": 0, "C": 0}}, "D missing"),
    ({"total": 30, "parts": {"A": 30, "B": 0, "C": 0, "D": 0}}, "not total and parts"),
    ({"total": 30.5}, "= 30.5 is out of range"),
    ({"total": True}, "= True is out of range"),
])
def test_fugl_meyer_given_wrong_is_refused_saying_what_to_give(given, words):
    with pytest.raises(InvalidRecordError) as caught:
        score("fugl_meyer", **given)
    assert words in str(caught.value)
    assert "\n" not in str(caught.value)


def test_arat_ashworth_pain_and_fatigue_in_their_forms():
    assert score("arat", parts={"grasp": 18, "grip": 6, "pinch": 3, "gross": 9}).total == 36
    with pytest.raises(InvalidRecordError, match="ARAT grip = 13 is out of range; give a "
                                                 "whole number 0-12"):
        score("arat", parts={"grasp": 18, "grip": 13, "pinch": 3, "gross": 9})
    graded = score("ashworth", grades={"elbow_flexors": "1+", "wrist_flexors": 2})
    assert (graded.total, graded.detail) == (None, {"grades": {"elbow_flexors": "1+",
                                                               "wrist_flexors": "2"}})
    for wrong, words in (({"elbow_flexors": "5"}, "is not a grade; give one of 0, 1, 1+"),
                         ({"knee_flexors": "1"}, "knee_flexors unknown"),
                         ({}, "at least one muscle group")):
        with pytest.raises(InvalidRecordError, match=words.replace("+", r"\+")):
            score("ashworth", grades=wrong)
    with pytest.raises(InvalidRecordError, match="has no total"):
        score("ashworth", total=2)
    with pytest.raises(InvalidRecordError, match="scale 'fma' unknown"):
        score("fma", total=2)
    assert len(ASHWORTH_GRADES) == 6
    assert set(SCALES) >= {"pain", "fatigue"}


def test_scales_are_kept_per_session_with_who_and_when_and_a_new_entry_supersedes(registry):
    code = registry.create_patient("Ada", "Example").code
    registry.open_session(code)
    first = registry.record_scale(code, 1, "fugl_meyer", total=20, rater="K. Lee")
    registry.record_scale(code, 1, "pain", total=3, rater="K. Lee")
    again = registry.record_scale(code, 1, "fugl_meyer",
                                  parts={"A": 14, "B": 3, "C": 4, "D": 2}, rater="M. Roy")
    assert (first.rater, first.total, again.total) == ("K. Lee", 20, 23)
    assert first.recorded_at <= again.recorded_at
    assert [e.id for e in registry.scale_entries(code)] == [first.id, first.id + 1, again.id]
    current = registry.session_scales(code)[1]
    assert current["fugl_meyer"] == again
    assert again.values() == {"fugl_meyer": 23.0, "fugl_meyer_A": 14.0, "fugl_meyer_B": 3.0,
                              "fugl_meyer_C": 4.0, "fugl_meyer_D": 2.0}
    assert registry.study_scales() == {code: {1: current}}
    with pytest.raises(InvalidRecordError, match="rater: give the name"):
        registry.record_scale(code, 1, "pain", total=2, rater=" ")
    with pytest.raises(InvalidRecordError, match="Pain \\(NRS\\) = 11 is out of range"):
        registry.record_scale(code, 1, "pain", total=11, rater="K. Lee")
    with pytest.raises(RegistryError, match="has no session 3"):
        registry.record_scale(code, 3, "pain", total=2, rater="K. Lee")
    assert len(registry.scale_entries(code)) == 3  # nothing stored by a refusal


def test_a_scale_or_a_note_before_the_first_trial_opens_the_session_the_trial_goes_on(
        registry):
    """Therapists take the Fugl-Meyer, ARAT, Ashworth, pain and fatigue at the start of a
    session, before the robot's first trial: it was refused ("a session begins with its
    first trial"). The patient's next session number opens the session, numbered where a
    trial numbers it; the trials after it go on in it; any other number is refused in one
    line naming the numbers possible, nothing stored."""
    code = registry.create_patient("Ada", "Example").code
    with pytest.raises(SessionNotFound) as refused:
        registry.record_scale(code, 2, "pain", total=3, rater="K. Lee")
    assert str(refused.value) == (f"patient {code} has no session 2; they have none yet: "
                                  "give 1, which opens their first")
    first = registry.record_scale(code, 1, "fugl_meyer", total=20, rater="K. Lee")
    registry.record_scale(code, 1, "pain", total=3, rater="K. Lee")
    assert first.session_number == 1
    day = first.session_date
    assert registry.suggest_registration(code, today=day) == Registration(code, 1, 1, False)
    # at Start (the session's day: a run across midnight opens the next, as ever)
    noon = datetime.datetime.combine(day, datetime.time(12)).astimezone()
    begun = registry.begin_trial(code, THESIS_SUBJECT, backend="simulator", started_at=noon)
    again = registry.begin_trial(code, THESIS_SUBJECT, backend="simulator", session_number=1)
    assert [(begun.session_number, begun.trial_number),
            (again.session_number, again.trial_number)] == [(1, 1), (1, 2)]
    assert [(s.number, s.n_trials) for s in registry.sessions(code)] == [(1, 2)]
    assert set(registry.session_scales(code)) == {1}

    note = registry.add_note(code, 2, "came in tired", author="K. Lee")  # a note opens too
    assert note.session_number == 2
    third = registry.begin_trial(code, THESIS_SUBJECT, backend="simulator", session_number=2)
    assert (third.session_number, third.trial_number) == (2, 1)
    assert registry.record_scale(code, 1, "arat", total=30, rater="M. Roy"  # a past one
                                 ).session_number == 1

    typo = (f"patient {code} has no session 9; give one of their sessions (1 and 2) or 3, "
            "which opens the next")
    for record in (lambda: registry.record_scale(code, 9, "pain", total=3, rater="K. Lee"),
                   lambda: registry.add_note(code, 9, "typo", author="K. Lee")):
        with pytest.raises(SessionNotFound) as refused:
            record()
        assert str(refused.value) == typo
    assert [(s.number, s.n_trials) for s in registry.sessions(code)] == [(1, 2), (2, 1)]
    assert len(registry.scale_entries(code)) == 3
    assert len(registry.notes(code)) == 1


def test_what_a_therapist_recorded_cannot_be_changed_or_deleted(registry):
    code = registry.create_patient("Ada", "Example").code
    registry.open_session(code)
    registry.record_scale(code, 1, "pain", total=3, rater="K. Lee")
    registry.add_note(code, 1, "tired today", author="K. Lee")
    # through the console's own connection (its seals, on the server its station's login)
    for statement in ("UPDATE scales SET total = 4", "DELETE FROM scales",
                      "UPDATE notes SET text = 'fine'", "DELETE FROM notes"):
        with pytest.raises(RegistryError, match=r"kept as written|may not do that"), \
                registry._write() as conn:
            conn.exec_driver_sql(statement)
    assert registry.notes(code)[0].text == "tired today"
    assert registry.scale_entries(code)[0].total == 3


# -- notes ------------------------------------------------------------------------------

def test_notes_on_a_session_and_on_its_trials_in_order(registry):
    code = registry.create_patient("Ada", "Example").code
    trial_id = finished_trial(registry, code)
    other = registry.create_patient("Bo", "Sample").code
    other_trial = finished_trial(registry, other)
    session_note = registry.add_note(code, 1, " shoulder pain before the start ",
                                     author="K. Lee")
    trial_note = registry.add_note(code, 1, "coughed at 12 s", author="K. Lee",
                                   trial_id=trial_id)
    assert session_note.text == "shoulder pain before the start"
    assert (session_note.trial_id, trial_note.trial_id) == (None, trial_id)
    assert registry.notes(code) == [session_note, trial_note] == registry.notes(code, 1)
    with pytest.raises(InvalidRecordError, match=f"trial {other_trial} is patient {other}"):
        registry.add_note(code, 1, "wrong trial", author="K. Lee", trial_id=other_trial)
    with pytest.raises(InvalidRecordError, match="note: write something"):
        registry.add_note(code, 1, "  ", author="K. Lee")
    assert len(registry.notes(code)) == 2


# -- validity ---------------------------------------------------------------------------

def test_an_invalid_trial_leaves_progress_and_comparisons_and_comes_back_when_asked(registry):
    code = registry.create_patient("Ada", "Example").code
    first = finished_trial(registry, code)
    second = finished_trial(registry, code)
    third = finished_trial(registry, code)
    mark = registry.mark_trial(second, valid=False, reason="patient let go of the handle",
                               by="K. Lee")
    assert (mark.valid, mark.reason, mark.marked_by) == (False, "patient let go of the "
                                                         "handle", "K. Lee")
    assert [t.id for t in registry.trial_summaries(code)] == [first, third]
    every = registry.trial_summaries(code, include_invalid=True)
    assert [(t.id, t.invalid_reason) for t in every] == [
        (first, None), (second, "patient let go of the handle"), (third, None)]
    assert registry.previous_trial(third).id == first
    assert registry.previous_trial(third, include_invalid=True).id == second
    assert set(registry.invalid_trials(code)) == {second}
    # the trial itself is untouched
    assert registry.trial(second).status == "complete"

    restored = registry.mark_trial(second, valid=True, reason="the grip was fine on replay",
                                   by="M. Roy")
    assert [m.valid for m in registry.trial_marks(second)] == [False, True]
    assert restored.marked_by == "M. Roy"
    assert [t.id for t in registry.trial_summaries(code)] == [first, second, third]
    assert registry.invalid_trials() == {}
    with pytest.raises(InvalidRecordError, match=f"trial {second} is already valid"):
        registry.mark_trial(second, valid=True, reason="again", by="M. Roy")
    with pytest.raises(InvalidRecordError, match="reason: say why"):
        registry.mark_trial(first, valid=False, reason="", by="M. Roy")
    assert registry.trial_marks(first) == []


def test_an_invalid_trials_proposal_is_not_offered_and_the_one_it_decided_is(registry):
    code = registry.create_patient("Ada", "Example").code
    first = finished_trial(registry, code)
    registry.record_proposal(first, {"reason": "after the first"})
    second = finished_trial(registry, code)
    registry.record_proposal(second, {"reason": "after the second"})
    assert registry.pending_proposal(code).trial_id == second
    registry.mark_trial(second, valid=False, reason="the robot was bumped", by="K. Lee")
    assert registry.pending_proposal(code).trial_id == first
    third = finished_trial(registry, code)
    assert registry.proposal(first).next_trial_id == third
    assert registry.pending_proposal(code) is None


def test_a_trial_still_recording_cannot_be_marked(registry):
    code = registry.create_patient("Ada", "Example").code
    begun = registry.begin_trial(code, TrialParameters(), backend="simulator")
    with pytest.raises(InvalidRecordError, match="still recording"):
        registry.mark_trial(begun.trial_id, valid=False, reason="x", by="K. Lee")


# -- corrections ------------------------------------------------------------------------

def test_a_correction_changes_the_patient_and_keeps_its_audit(registry):
    code = registry.create_patient("Ada", "Example", upper_arm_m=0.31, birth_year=1950).code
    corrected = registry.correct_patient(code, "upper_arm_m", 0.29,
                                         reason="measured again with the calliper",
                                         by="K. Lee")
    registry.correct_patient(code, "shoulder_m", (-0.1, 0.7), reason="moved chair",
                             by="K. Lee")
    registry.correct_patient(code, "sex", "male", reason="typed wrong", by="M. Roy")
    assert corrected.upper_arm_m == 0.29
    assert registry.patient(code).shoulder_m == (-0.1, 0.7)
    trail = registry.corrections(code)
    assert [(c.field, c.old_value, c.new_value, c.corrected_by) for c in trail] == [
        ("upper_arm_m", 0.31, 0.29, "K. Lee"), ("shoulder_m", None, [-0.1, 0.7], "K. Lee"),
        ("sex", None, "male", "M. Roy")]
    assert trail[0].reason == "measured again with the calliper"
    for field, value, words in (("upper_arm_m", 0.9, "upper_arm_m"),
                                ("birth_year", 1800, "birth_year"),
                                ("code", "PAAAAAA", "cannot be corrected"),
                                ("upper_arm_m", 0.29, "nothing to correct")):
        with pytest.raises(InvalidRecordError, match=words):
            registry.correct_patient(code, field, value, reason="why", by="K. Lee")
    with pytest.raises(InvalidRecordError, match="reason: say why"):
        registry.correct_patient(code, "upper_arm_m", 0.3, reason=" ", by="K. Lee")
    assert len(registry.corrections(code)) == 3
    assert registry.patient(code).upper_arm_m == 0.29


@settings(max_examples=25, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(values=st.lists(st.floats(0.15, 0.5, allow_nan=False), min_size=1, max_size=5))
def test_the_audit_replays_to_the_patients_value(registry, values):
    """Property: the corrections' chain from the first old value reaches the row's value,
    each old value being the previous new one."""
    code = registry.create_patient("Ada", "Example", forearm_m=0.27).code
    for value in values:
        with contextlib.suppress(InvalidRecordError):  # equal to the last: nothing to do
            registry.correct_patient(code, "forearm_m", value, reason="re-measured", by="K")
    trail = registry.corrections(code)
    current = 0.27
    for correction in trail:
        assert correction.old_value == current
        current = correction.new_value
    assert registry.patient(code).forearm_m == current
