"""The thesis's data set made of synthetic subjects, and the models validated on it."""

import numpy as np
import pytest

from app.emg.subjects import THESIS_SESSIONS, model_data, thesis_design
from core.emg.models import LinearModel, MuscleModel, leave_one_subject_out, validate
from core.emg.mvc import BELOW_TRIAL
from core.emg.synthetic import THESIS_MUSCLES
from device.recording.emgfile import read_emg


@pytest.fixture(scope="module")
def design(tmp_path_factory):
    return thesis_design(tmp_path_factory.mktemp("design"), subjects=2)


def test_the_design_has_the_thesis_sessions_and_subject_2s_bad_deltoid(design):
    assert len(design) == 2 * sum(n for _, n in THESIS_SESSIONS)
    for subject, session, path in design:
        emg = read_emg(path)
        assert emg.muscles == THESIS_MUSCLES
        flags = emg.mvc["anterior_deltoid"]["flags"]
        assert (BELOW_TRIAL in flags) == (subject.number == 2), (subject.number, session)
        assert emg.mvc["biceps"]["flags"] == []


def test_models_are_scored_held_out_against_the_baseline(design):
    trials = [model_data(path, subject.number) for subject, _, path in design]
    for t in trials:
        assert t.u.shape[1] == 3
        assert len(t.u) > 100
        assert np.isfinite(t.u).all()
        assert np.isfinite(t.torques).all()
    v = validate(lambda: MuscleModel(THESIS_MUSCLES), trials, {trials[-1].name}, "thesis split")
    assert v.test == (trials[-1].name,)
    assert np.isfinite(v.score.rmse_Nm).all()
    assert np.isfinite(v.baseline.rmse_Nm).all()
    assert v.usable == (v.why_not == "")
    loso = leave_one_subject_out(LinearModel, trials)
    assert [r.split for r in loso] == ["leave subject 1 out", "leave subject 2 out"]
