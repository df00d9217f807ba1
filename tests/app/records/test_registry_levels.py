"""The registry keeps what each trial ran (issue 27, items 5 and 10): the assistance levels
in effect (schema v5), proposals decided against every parameter, and the proposal that
waits for the next trial, after a restart too."""

from __future__ import annotations

import json
import math

import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from app.errors import InvalidRecordError
from app.records.assistance import AssistanceInEffect
from app.records.datadir import DataDir
from app.records.registry import SCHEMA_VERSION, Registry
from app.records.registry.proposals import _decision
from core.trial import THESIS_SUBJECT, TrialParameters
from tests.app.records.history import registry_at

A = THESIS_SUBJECT.replace(assist="as-needed")
PROPOSAL = {"assistance_level": 0.5, "duration_s": 4.0, "tolerance_rad": A.tolerance_rad,
            "change": "assistance", "reason": "led 85 %: less assistance, 60 % → 50 %",
            "level_step": -0.1, "speed_step": 0.0}


def make_v4_registry(folder) -> None:
    """A registry as the console left it at schema v4: a patient, a finished trial and its
    proposal, pending."""
    with registry_at(folder, 4) as conn:
        conn.execute("INSERT INTO patients (code, created_at) VALUES ('PABC234', "
                     "'2026-11-05T10:00:00+00:00')")
        conn.execute("INSERT INTO sessions (patient_id, number, date) VALUES (1, 1, "
                     "'2026-11-05')")
        conn.execute(
            "INSERT INTO trials (session_id, number, parameters, file, status, started_at, "
            "ended_at, backend) VALUES (1, 1, ?, 'trials/PABC234/t1.h5', 'complete', "
            "'2026-11-05T10:05:00+00:00', '2026-11-05T10:05:40+00:00', 'simulator')",
            (json.dumps(A.to_dict()),))
        conn.execute("INSERT INTO proposals (trial_id, proposal, proposed_at) VALUES "
                     "(1, ?, '2026-11-05T10:05:41+00:00')", (json.dumps(PROPOSAL),))


def test_a_v4_registry_is_upgraded_and_keeps_the_levels_trials_ran_from_then_on(tmp_path):
    make_v4_registry(tmp_path / "data")
    registry = Registry(DataDir(tmp_path / "data"))
    assert registry.schema_version() == SCHEMA_VERSION == 13
    assert list((tmp_path / "data").glob("registry.sqlite3.v4-*.bak"))
    (old,) = registry.trials_for_patient("PABC234")
    assert old.assistance is None  # before v5: only the built level is known
    assert old.assist == "as-needed"
    # the pending proposal of the old registry is the one waiting after the upgrade
    waiting = registry.pending_proposal("PABC234")
    assert (waiting.trial_id, waiting.proposal) == (1, PROPOSAL)

    ran = AssistanceInEffect(((0.0, 1.0), (5.8, 0.6)))
    begun = registry.begin_trial("PABC234", A, backend="simulator", session_number=1)
    finished = registry.finish_trial(begun.trial_id, "complete", {}, reason="",
                                     assistance=ran)
    assert finished.assistance == ran
    assert registry.trial(begun.trial_id).assistance.summary() == "100 % → 60 % at 5.8 s"
    summaries = registry.trial_summaries("PABC234")
    assert [(t.assist, t.assistance) for t in summaries] == [("as-needed", None),
                                                              ("as-needed", ran)]
    assert registry.integrity_check() == []


def test_levels_out_of_range_are_refused_and_nothing_is_stored(open_registry):
    registry = open_registry()
    code = registry.create_patient("Ada", "Example").code
    begun = registry.begin_trial(code, A, backend="simulator")
    with pytest.raises(InvalidRecordError, match="each from 0 to 1"):
        registry.finish_trial(begun.trial_id, "complete", {},
                              assistance=AssistanceInEffect(((0.0, 1.0), (2.0, math.nan))))
    assert not registry.trial(begun.trial_id).finished


def test_accepted_only_when_the_next_trial_is_the_proposal_applied_to_the_one_before(
        open_registry):
    """Issue 27, item 10: 'accepted' was recorded when the next trial changed its shape and
    mode but had the proposed level, pace and tolerance."""
    registry = open_registry()
    code = registry.create_patient("Ada", "Example").code
    before = A.replace(assistance_level=0.6)
    proposal = dict(PROPOSAL)
    proposed = before.replace(assistance_level=0.5)

    def next_trial(parameters):
        first = registry.begin_trial(code, before, backend="simulator")
        registry.finish_trial(first.trial_id, "complete", {})
        registry.record_proposal(first.trial_id, proposal)
        assert registry.pending_proposal(code).trial_id == first.trial_id
        second = registry.begin_trial(code, parameters, backend="simulator")
        registry.finish_trial(second.trial_id, "complete", {})
        assert registry.pending_proposal(code) is None
        return registry.proposal(first.trial_id).decision

    assert next_trial(proposed) == "accepted"
    assert next_trial(proposed.replace(shape="circle", assist="thesis")) == "changed"
    assert next_trial(proposed.replace(radius_m=0.08)) == "changed"
    assert next_trial(before) == "kept"
    assert next_trial(before.replace(controller="ctpid")) == "changed"


FIELDS = {
    "shape": st.sampled_from(["d", "circle"]),
    "assist": st.sampled_from(["thesis", "as-needed"]),
    "radius_m": st.sampled_from([0.08, 0.10]),
    "duration_s": st.sampled_from([3.6, 4.0]),
    "assistance_level": st.sampled_from([0.5, 0.6, 1.0]),
    "repetitions": st.sampled_from([3, 5]),
    "controller": st.sampled_from(["smc", "ctpid"]),
}


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(before=st.fixed_dictionaries(FIELDS), after=st.fixed_dictionaries(FIELDS),
       level=st.sampled_from([0.5, 0.6, 1.0]), duration=st.sampled_from([3.6, 4.0]))
def test_the_decision_is_accepted_exactly_when_every_parameter_is_the_proposals(
        before, after, level, duration):
    b, a = TrialParameters(**before), TrialParameters(**after)
    proposal = {**PROPOSAL, "assistance_level": level, "duration_s": duration,
                "tolerance_rad": b.tolerance_rad}
    decision = _decision(proposal, b, a)
    proposed = b.replace(assistance_level=level, duration_s=duration)
    assert (decision == "accepted") == (a == proposed)
    assert (decision == "kept") == (a == b and a != proposed)
    assert (decision == "changed") == (a != proposed and a != b)
