"""Z-scores and the task score from a hand-made norms file equal the values computed by hand
(the arithmetic in the comments; statistics.NormalDist for Φ, not the code's scipy)."""

from __future__ import annotations

import json
import math
from statistics import NormalDist

import pytest
from hypothesis import given, settings, strategies as st

from app.norms import SIMULATED_LABEL, Covariates, NormsError, load_norms, write_norms
from tests.app.norms.handmade import handmade

N = NormalDist()
PERSON = Covariates(age_years=60, sex="male", handedness="right", tested_side="left",
                    robot="simulator-realistic")


def half_normal_quantile(z: float) -> float:
    return N.inv_cdf((1.0 + N.cdf(z)) / 2.0)


@pytest.fixture
def model(tmp_path):
    path = tmp_path / "norms.json"
    path.write_text(json.dumps(handmade()))
    return load_norms(path)


def test_figure_z_by_hand(model):
    # t = (√0.49 − 1)/0.5 = −0.6; expected −1 + 0.01·60 + 0.05 (male) + 0.02 (left) = −0.33
    z = model.z("vgr_reaction_time_s", 0.49, PERSON)
    assert z.z == pytest.approx((-0.6 + 0.33) / 0.1, abs=1e-12)  # −2.7: faster than healthy
    assert z.worse_z == pytest.approx(-2.7)
    assert not z.extrapolated
    # untransformed: expected 0.5 − 0.002·60 = 0.38; (0.3 − 0.38)/0.05 = −1.6, worse +1.6
    speed = model.z("vgr_max_speed_m_s", 0.3, PERSON)
    assert speed.z == pytest.approx(-1.6, abs=1e-12)
    assert speed.worse_z == pytest.approx(1.6, abs=1e-12)
    assert z.source == "hand-made for the tests, 3 Dec 2026"
    assert not z.simulated


def test_task_score_by_hand(model):
    metrics = {"vgr_reaction_time_s": 0.49, "vgr_max_speed_m_s": 0.3, "vgr_sparc": -1.6}
    d = math.hypot(half_normal_quantile(-2.7), half_normal_quantile(1.6))
    z_task = ((math.sqrt(d) - 1.0) / 0.5 - 1.0) / 0.4
    score = model.task_score("reaching", metrics, PERSON)
    assert score.distance == pytest.approx(d, abs=1e-9)
    assert score.z_task == pytest.approx(z_task, abs=1e-9)
    assert score.score == pytest.approx(half_normal_quantile(z_task), abs=1e-9)
    assert score.score >= 0.0
    assert set(score.figures) == {"vgr_reaction_time_s", "vgr_max_speed_m_s"}


def test_an_older_person_is_extrapolated_not_refused(model):
    old = Covariates(90, "female", "right", "right", "simulator-realistic")
    # expected −1 + 0.9 = −0.1; t(0.49) = −0.6 → Z = −5
    z = model.z("vgr_reaction_time_s", 0.49, old)
    assert z.z == pytest.approx(-5.0)
    assert z.extrapolated


def test_what_the_norms_cannot_answer_is_one_line(model):
    hardware = Covariates(60, "male", "right", "left", "quanser-2dof")
    with pytest.raises(NormsError, match="robot 'quanser-2dof'"):
        model.z("vgr_reaction_time_s", 0.5, hardware)
    with pytest.raises(NormsError, match="no figure 'circle_ratio'"):
        model.z("circle_ratio", 0.9, PERSON)
    with pytest.raises(NormsError, match="Box-Cox domain"):
        model.z("vgr_reaction_time_s", -0.1, PERSON)
    with pytest.raises(NormsError, match="not a finite number"):
        model.z("vgr_reaction_time_s", math.nan, PERSON)
    with pytest.raises(NormsError, match="needs vgr_max_speed_m_s"):
        model.task_score("reaching", {"vgr_reaction_time_s": 0.5}, PERSON)
    with pytest.raises(NormsError, match="no task score for 'circle'"):
        model.task_score("circle", {}, PERSON)
    with pytest.raises(NormsError, match="no MDC95 for vgr_max_speed_m_s"):
        model.is_real_change("vgr_max_speed_m_s", 0.3, 0.5)
    for exc in (NormsError("x"),):
        assert "\n" not in str(exc)


def test_real_change_against_the_files_mdc(model):
    assert model.is_real_change("vgr_reaction_time_s", 0.50, 0.40).real  # 0.10 > 0.08
    assert not model.is_real_change("vgr_reaction_time_s", 0.50, 0.43).real  # 0.07
    change = model.is_real_change("task:reaching", 2.0, 0.9)  # 1.1 > 0.9
    assert change.real
    assert change.mdc95 == 0.9


def test_simulated_norms_say_so(tmp_path):
    document = handmade()
    document["simulated"] = True
    path = write_norms(tmp_path / "sim.json", document)
    model = load_norms(path)
    assert model.simulated
    assert SIMULATED_LABEL in model.label
    assert model.z("vgr_max_speed_m_s", 0.3, PERSON).simulated
    assert SIMULATED_LABEL == "simulated — for demonstration and tests only"


def test_written_file_round_trips_and_carries_its_hash(tmp_path):
    path = write_norms(tmp_path / "n.json", handmade())
    stored = json.loads(path.read_text())
    assert len(stored["content_sha256"]) == 64
    assert load_norms(path).content_sha256 == stored["content_sha256"]


def test_a_value_beyond_the_transform_is_refused(model):
    with pytest.raises(NormsError, match="overflows"):
        model.z("vgr_max_speed_m_s", 1e308, PERSON)


PEOPLE = st.builds(Covariates, st.floats(20, 80), st.sampled_from(["female", "male"]),
                   st.sampled_from(["right", "left"]), st.sampled_from(["right", "left"]),
                   st.just("simulator-realistic"))


@settings(max_examples=200, deadline=None)
@given(PEOPLE, st.floats(-4, 4))
def test_the_value_k_sds_from_expected_has_z_k(tmp_path_factory, person, k):
    """Invariant: the figure whose transformed value lies k residual SDs from the expected
    one (t⁻¹(t̂ + k·σ)) has Z = k, for any person and both transforms."""
    path = tmp_path_factory.mktemp("n") / "n.json"
    path.write_text(json.dumps(handmade()))
    norms = load_norms(path)
    for key in ("vgr_reaction_time_s", "vgr_max_speed_m_s"):
        norm = norms.figures[key]
        expected = float(norm.regression.predict(norms.covariates, [person])[0])
        value = float(norm.transform.invert(expected + k * norm.regression.residual_sd))
        assert norms.z(key, value, person).z == pytest.approx(k, abs=1e-6)


@settings(max_examples=200, deadline=None)
@given(PEOPLE, st.floats(0.05, 2.0), st.floats(0.05, 2.0), st.floats(0.0, 0.5))
def test_worse_never_scores_better(tmp_path_factory, person, rt, extra, speed):
    """Invariant: a slower reaction (worse) or a lower peak speed (worse) never lowers the
    task score; the score is never negative."""
    path = tmp_path_factory.mktemp("n") / "n.json"
    path.write_text(json.dumps(handmade()))
    norms = load_norms(path)
    base = norms.task_score("reaching", {"vgr_reaction_time_s": rt,
                                         "vgr_max_speed_m_s": speed}, person).score
    slower = norms.task_score("reaching", {"vgr_reaction_time_s": rt + extra,
                                           "vgr_max_speed_m_s": speed}, person).score
    weaker = norms.task_score("reaching", {"vgr_reaction_time_s": rt,
                                           "vgr_max_speed_m_s": speed - extra / 4}, person).score
    assert base >= 0.0
    assert slower >= base - 1e-9
    assert weaker >= base - 1e-9


def test_undefined_figures_are_left_out_not_refused(model):
    """A trial's metrics hold NaN where a figure was undefined: z_scores leaves it out and
    scores the rest; the task score says it lacks it."""
    metrics = {"vgr_reaction_time_s": math.nan, "vgr_max_speed_m_s": 0.3}
    z = model.z_scores(metrics, PERSON)
    assert set(z) == {"vgr_max_speed_m_s"}
    with pytest.raises(NormsError, match="needs vgr_reaction_time_s"):
        model.task_score("reaching", metrics, PERSON)
    with pytest.raises(NormsError, match="not a finite number"):
        model.z_scores({"vgr_max_speed_m_s": math.inf}, PERSON)


def test_a_task_not_performed_is_named_not_a_gap(model):
    """The passive patient: no reaction in any reach, so the reaction time is undefined. The
    task is not performed — worse than any task score — rather than "needs a figure"."""
    from app.norms import TaskNotPerformed

    metrics = {"vgr_reaction_time_s": math.nan, "vgr_max_speed_m_s": 0.0,
               "vgr_no_reaction_count": 16.0}
    with pytest.raises(TaskNotPerformed, match="no reaction in any of the 16 reaches") as err:
        model.task_score("reaching", metrics, PERSON)
    assert err.value.task == "reaching"
    assert "worse than any task score" in str(err.value)
    # One reach with a reaction is a performed task with a figure the score lacks.
    with pytest.raises(NormsError, match="needs vgr_reaction_time_s") as err:
        model.task_score("reaching", {**metrics, "vgr_no_reaction_count": 15.0}, PERSON)
    assert not isinstance(err.value, TaskNotPerformed)
