"""EMG in place of the force sensor (thesis chapter 5's cHRI aim): the approved model's
file and its refusals, the replayed validation that uses only the EMG that had arrived,
and the closed loop, where the assistance judges the force estimated from a synthetic
subject's EMG made while the trial runs."""

import dataclasses
import json
import math
import shutil

import h5py
import numpy as np
import pytest

from app.emg.estimate import replay_trial
from app.emg.feed import SyntheticEmgFeed
from app.emg.modelfile import emg_model, read_emg_model, save_approved
from app.emg.subjects import Subject
from app.emg.validation import ModelNotApproved
from app.learning.modelfile import ModelFileError, content_hash
from app.trials.headless import simulate_to_file
from app.trials.reader import read_trial
from core.emg.force import in_cone
from core.emg.models import FeedForwardNetwork
from core.trial import THESIS_SUBJECT
from device.loop.pipeline import PERIOD_S
from tests.emg_subjects import WIDE_CONE_RAD
from tests.trialfiles import edited

SUBJECT = Subject.drawn(1)
LATENCY = SyntheticEmgFeed.latency_of(SUBJECT)


@pytest.fixture(scope="module")
def session(emg_subject_1):
    return list(emg_subject_1)  # recorded once for the run (tests/conftest.py)


@pytest.fixture(scope="module")
def checked(emg_model_1):
    return emg_model_1  # subject 1's model at LATENCY, checked once for the run


@pytest.fixture(scope="module")
def saved(checked, tmp_path_factory):
    models = tmp_path_factory.mktemp("models")
    save_approved(models, "s1", checked)
    return models, emg_model(models, "s1")


def test_an_approval_edited_to_a_narrower_cone_and_rehashed_is_refused(saved):
    """Issue 28 #11: the validated cone edited from 30° to the thesis's 20° and the content
    hash recomputed made a 20° trial pass that the original approval refuses."""
    models, original = saved
    assert original.refusal(THESIS_SUBJECT, 0.0)  # the original: not at 20°
    document = json.loads(original.path.read_text())
    for v in document["validations"]:
        v["force"]["tolerance_rad"] = THESIS_SUBJECT.tolerance_rad
    document["content_sha256"] = content_hash(document)
    (models / "emg" / "edited.json").write_text(json.dumps(document))
    with pytest.raises(ModelFileError, match="signature: it was changed after it was "
                                             "signed"):
        emg_model(models, "edited")


def test_the_validation_replays_the_held_out_trial_as_the_live_console_would(checked):
    v = checked.validations[0]
    assert v.usable, v.why_not
    assert v.force.tolerance_rad == pytest.approx(WIDE_CONE_RAD)
    assert v.force.cone_agreement >= 0.8
    # the same model at the thesis's 20°: the force it implies misjudges the narrower cone
    _ticks, estimate, force, direction, _ = replay_trial(
        checked.model, checked.muscles, checked.settings, checked.dt_s, checked.trials[-1],
        as_live=True, latency_s=LATENCY)
    alike = np.mean(in_cone(estimate, direction, math.radians(20))
                    == in_cone(force, direction, math.radians(20)))
    assert alike < v.force.cone_agreement


def test_the_replay_uses_only_the_emg_that_had_arrived(checked, tmp_path):
    """Scrambling the EMG after a moment changes no estimate made before it (less the
    source's latency): the validation cannot peek at the future."""
    source = checked.trials[-1]
    copy = shutil.copy(source, tmp_path / "scrambled.h5")
    cut_s = 3.0
    with edited(copy) as f:
        t = f["emg/time"][()]
        samples = f["emg/samples"][()]
        later = t > cut_s
        samples[later] = np.random.default_rng(0).normal(0, 1e-3, samples[later].shape)
        f["emg/samples"][...] = samples
    args = (checked.model, checked.muscles, checked.settings, checked.dt_s)
    ticks, before, *_ = replay_trial(*args, source, as_live=True, latency_s=LATENCY)
    _, after, *_ = replay_trial(*args, copy, as_live=True, latency_s=LATENCY)
    time_s = read_trial(source).channels["time"][ticks]
    early = time_s - LATENCY <= cut_s
    np.testing.assert_array_equal(after[early], before[early])
    assert not np.allclose(after[~early], before[~early])


def test_the_model_file_holds_what_passed_and_refuses_what_did_not(saved, checked, tmp_path):
    models, model = saved
    path = models / "emg" / "s1.json"
    assert path.stat().st_mode & 0o777 == 0o600
    assert model.muscles == checked.muscles
    assert model.as_live
    assert model.latency_s == LATENCY
    assert "held-out R²" in model.summary
    # a trial with a narrower cone, or a later source, is refused in words
    assert "validated with a 30° tolerance cone" in model.refusal(THESIS_SUBJECT, LATENCY)
    assert model.refusal(THESIS_SUBJECT.replace(tolerance_rad=WIDE_CONE_RAD), LATENCY) == ""
    assert "arriving 40 ms late" in model.refusal(
        THESIS_SUBJECT.replace(tolerance_rad=WIDE_CONE_RAD), 0.1)
    # never saved over
    with pytest.raises(ModelFileError, match="already exists"):
        save_approved(models, "s1", checked)
    # a failed validation is not saved at all
    failing = dataclasses.replace(checked, validations=[dataclasses.replace(
        checked.validations[0], force=dataclasses.replace(checked.validations[0].force,
                                                          cone_agreement=0.5))])
    with pytest.raises(ModelNotApproved, match="below 80%"):
        save_approved(models, "failing", failing)
    assert not (models / "emg" / "failing.json").exists()
    # a file edited by hand: its hash; re-hashed to look valid, its rule still applies
    document = json.loads(path.read_text())
    document["validations"][0]["force"]["cone_agreement"] = 0.5
    edited = tmp_path / "edited.json"
    edited.write_text(json.dumps(document))
    with pytest.raises(ModelFileError, match="content hash"):
        read_emg_model(edited)
    document["content_sha256"] = content_hash(document)
    edited.write_text(json.dumps(document))
    # re-hashed, it is no longer signed by this installation (issue 28 #11)
    with pytest.raises(ModelFileError, match="signature"):
        read_emg_model(edited)
    # even signed here (as `rehab models import` would), the console's rule applies
    from app.records import signing

    edited.write_text(json.dumps(signing.sign(document)))
    with pytest.raises(ModelFileError, match="not approved"):
        read_emg_model(edited)
    document["validations"][0]["force"]["cone_agreement"] = 0.95
    document["validations"][0]["threshold_agreement"] = 0.0  # a file cannot lower the bar
    document["validations"][0]["force"]["cone_agreement"] = 0.7
    document["content_sha256"] = content_hash(document)
    edited.write_text(json.dumps(signing.sign(document)))
    with pytest.raises(ModelFileError, match="not approved"):
        read_emg_model(edited)
    with pytest.raises(ModelFileError, match="muscles"):
        read_emg_model(path, muscles=("biceps", "triceps"))
    for broken in ("{", json.dumps({"format": "other"})):
        edited.write_text(broken)
        with pytest.raises(ModelFileError, match="format"):
            read_emg_model(edited)
    with pytest.raises(ModelFileError, match="missing"):
        read_emg_model(tmp_path / "none.json")


def _closed_loop(model, tmp_path, feed_type=SyntheticEmgFeed):
    params = THESIS_SUBJECT.replace(tolerance_rad=WIDE_CONE_RAD, repetitions=2,
                                    force_estimate=model.name,
                                    force_estimate_sha256=model.content_sha256)
    feed = feed_type(SUBJECT, model, params.arm(), period_s=PERIOD_S)
    path = tmp_path / "emg-fed.h5"
    trial, _analysis, problem = simulate_to_file(
        params, path, patient=SUBJECT.patient, feed=feed,
        patient_options={"drive_N": SUBJECT.drive_N})
    assert trial.status == "complete", problem
    return path, feed


def test_in_closed_loop_the_assistance_judges_the_push_as_the_sensor_would(saved, tmp_path):
    """The outcome: on the trial's exercise, the EMG-fed scheme's cone decisions (the
    records' assistance_active) agree with what the sensor's force would have decided on
    most ticks, as the replayed validation said (docs/validation.md has the figures)."""
    _, model = saved
    path, feed = _closed_loop(model, tmp_path)
    ch = read_trial(path).channels
    exercise = ch["phase"] == 2
    by_sensor = in_cone(ch["force"][exercise], ch["direction_desired"][exercise],
                        WIDE_CONE_RAD)
    by_emg = ch["assistance_active"][exercise]
    assert np.mean(by_sensor == by_emg) >= 0.8
    assert by_emg.mean() > 0.5  # it does give way
    # every estimate is in the file beside the sensor's force, with the EMG behind it
    with h5py.File(path, "r") as f:
        a = f["assistance"]
        assert a.attrs["estimate_model"] == "s1"
        assert a.attrs["estimate_model_sha256"] == model.content_sha256
        ticks = a["estimate_tick"][()].astype(int)  # stored as float64, as every array there
        assert np.all(np.diff(ticks)[:-1] == feed.every_ticks)  # the last: the trial ends
        estimate = a["estimate_force"][()]
        assert estimate.shape == (ticks.size, 2)
        assert set(f["emg/mvc"]) == set(model.muscles)
    error = estimate - ch["force"][ticks]
    assert np.sqrt(np.mean(error[:, 0] ** 2)) < np.sqrt(np.mean(ch["force"][ticks, 0] ** 2))


class _Lost(SyntheticEmgFeed):
    """The EMG stops after the first second: no estimate comes any more."""

    def __call__(self, records):
        if records[-1]["time"] < 1.0:
            super().__call__(records)


def test_when_the_emg_stops_the_assistance_stops_giving_way(saved, tmp_path):
    _, model = saved
    path, _ = _closed_loop(model, tmp_path, _Lost)
    ch = read_trial(path).channels
    late = (ch["phase"] == 2) & (ch["time"] > 1.0 + 0.3)
    assert late.any()
    assert not ch["assistance_active"][late].any()


def test_a_feed_is_refused_for_a_trial_on_the_force_sensor(saved, tmp_path):
    _, model = saved
    feed = SyntheticEmgFeed(SUBJECT, model, THESIS_SUBJECT.arm(), period_s=PERIOD_S)
    with pytest.raises(Exception, match="feed"):
        simulate_to_file(THESIS_SUBJECT.replace(repetitions=1), tmp_path / "x.h5", feed=feed)


def test_an_estimator_needs_every_muscle_s_mvc(checked):
    from app.emg.estimate import ForceEstimator
    from core.errors import ParameterError

    with pytest.raises(ParameterError, match="record the MVC of"):
        ForceEstimator(FeedForwardNetwork(), checked.muscles, checked.settings, 0.02,
                       {"biceps": 1e-3}, {"biceps": 0}, 1925.9, THESIS_SUBJECT.arm())
