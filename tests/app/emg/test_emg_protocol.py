"""The guided MVC protocol's parts without a window (app.emg.protocol): the steps on an
injected clock, the contraction's MVC and its refusals, a trial's live EMG stored under
the muscles' names with the session's MVCs checked against it, the live % MVC, and the
source words (app.emg.live.source_spec)."""

import dataclasses
import shutil

import numpy as np
import pytest

from app.emg.importing import EmgImportError
from app.emg.live import full_scale_of, source_spec
from app.emg.protocol import (
    PUSH,
    REST,
    SETTLE_S,
    WAITING,
    GuidedMvc,
    MvcRecord,
    SessionMvcs,
    contraction_mvc,
    live_percent,
    store_trial,
)
from app.emg.session import trial_envelopes
from app.trials.headless import save, simulate
from core.emg.mvc import BELOW_TRIAL
from core.emg.processing import EmgSettings
from core.trial import THESIS_SUBJECT
from device.emg.capture import Captured
from device.recording.emgfile import read_emg
from tests.trialfiles import edited

RATE = 2000.0


class Clock:
    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


def wave(n: int, levels, rate=RATE) -> np.ndarray:
    """(n, len(levels)) 97.3 Hz waves of the given amplitudes (V): RMS level/√2 (no
    period of a whole number of samples, so no extreme repeats as clipping would)."""
    k = np.arange(n)[:, None]
    return np.sin(2 * np.pi * 97.3 * k / rate) * np.asarray(levels)[None, :]


def test_the_steps_follow_the_clock():
    clock = Clock()
    guided = GuidedMvc("biceps", rest_s=3.0, push_s=5.0, clock=clock)
    step = guided.step()
    assert step.phase == REST
    assert step.text.startswith("biceps brachii: rest")
    clock.now += 3.2
    step = guided.step()
    assert step.phase == PUSH
    assert step.text.startswith("biceps brachii: PUSH as hard as you can: bend the elbow")
    assert step.text.endswith("… 5 s")
    clock.now += 4.0
    assert guided.step().text.endswith("… 1 s")
    clock.now += 1.0
    assert guided.step().phase == WAITING
    assert guided.push_span == (103.0, 108.0)
    assert not guided.ready(None)
    assert not guided.ready(107.9)
    assert guided.ready(108.0)
    assert not guided.late()
    clock.now = 108.0 + SETTLE_S + 0.01
    assert guided.late()


@pytest.mark.parametrize(("rest", "push"), [(-1.0, 5.0), (3.0, 0.0), (float("nan"), 5.0)])
def test_impossible_durations_are_refused(rest, push):
    with pytest.raises(EmgImportError, match="give a rest of 0 s or more"):
        GuidedMvc("biceps", rest_s=rest, push_s=push)


def test_a_contraction_gives_its_mvc_and_refuses_what_is_not_one():
    settings = EmgSettings()
    x = wave(int(3 * RATE), [1e-4, 4e-4])
    t = np.arange(x.shape[0]) / RATE
    mvc = contraction_mvc(t, x, RATE, "triceps", 1, settings=settings, full_scale_V=0.011,
                          wanted_s=3.0)
    assert mvc.ok
    assert mvc.value_V == pytest.approx(4e-4 / 2 ** 0.5, rel=0.02)
    with pytest.raises(EmgImportError, match="no EMG came during the contraction"):
        contraction_mvc(t[:1], x[:1], RATE, "triceps", 1, settings=settings,
                        full_scale_V=None, wanted_s=3.0)
    with pytest.raises(EmgImportError, match="channel 3 is not in the source"):
        contraction_mvc(t, x, RATE, "triceps", 2, settings=settings, full_scale_V=None,
                        wanted_s=3.0)
    with pytest.raises(EmgImportError, match=r"only 3\.0 s of EMG came during the 5 s"):
        contraction_mvc(t, x, RATE, "triceps", 1, settings=settings, full_scale_V=None,
                        wanted_s=5.0)


@pytest.fixture(scope="module")
def plain_trial(tmp_path_factory):
    path = tmp_path_factory.mktemp("trial") / "trial.h5"
    save(simulate(THESIS_SUBJECT.replace(repetitions=1), engine="python"), path)
    return path


def _session_with_mvcs(levels) -> SessionMvcs:
    """MVCs of biceps, triceps and deltoid on channels 3, 1 and 2 from waves of `levels`."""
    session = SessionMvcs("P1", 1, channels={"biceps": 2, "triceps": 0, "anterior_deltoid": 1})
    settings = EmgSettings()
    for muscle, level in zip(("biceps", "triceps", "anterior_deltoid"), levels, strict=True):
        x = wave(int(3 * RATE), [level])
        mvc = contraction_mvc(np.arange(x.shape[0]) / RATE, x, RATE, muscle, 0,
                              settings=settings, full_scale_V=None, wanted_s=3.0)
        session.records[muscle] = MvcRecord(mvc, session.channels[muscle], "trigno:x", settings)
    return session


def test_a_trials_live_emg_is_stored_by_muscle_with_the_session_mvcs(plain_trial, tmp_path):
    origin = 5000.0
    path = shutil.copy(plain_trial, tmp_path / "live.h5")
    with edited(path) as f:
        f["summary"].attrs["wall_time_origin_monotonic_s"] = origin
        duration = f["timeseries/time"][-1]
    # the trial's activity: triceps (ch 1) at half its MVC, deltoid (ch 2) above its MVC
    n = int((duration + 1.0) * RATE)
    captured = Captured(origin - 0.5 + np.arange(n) / RATE, wave(n, [1e-4, 3e-4, 1e-4, 9.0]),
                        RATE, 0, "")
    session = _session_with_mvcs([2e-4, 2e-4, 2e-4])
    done, checked = store_trial(path, captured, "trigno:x", session)
    assert done.muscles == ("biceps", "triceps", "anterior_deltoid")
    emg = read_emg(path)
    assert emg.names == ("EMG3", "EMG1", "EMG2")
    np.testing.assert_allclose(emg.samples[:, 0], captured.samples[:, 2])
    assert set(emg.mvc) == {"biceps", "triceps", "anterior_deltoid"}
    assert checked["triceps"].ok
    assert checked["biceps"].ok
    assert BELOW_TRIAL in checked["anterior_deltoid"].flags
    assert emg.mvc["anterior_deltoid"]["flags"] == [BELOW_TRIAL]
    assert emg.mvc["triceps"]["channel"] == "EMG1"
    assert session.trials == [path]
    env = trial_envelopes(path)
    inside = np.isfinite(env.values).all(axis=1)
    triceps = env.values[inside, env.muscles.index("triceps")]
    assert np.median(triceps) == pytest.approx(0.5, rel=0.05)
    # a muscle's channel beyond what the source has is refused, naming it
    session.channels["biceps"] = 7
    with pytest.raises(EmgImportError, match="channel 8 is chosen for a muscle"):
        store_trial(path, captured, "trigno:x", session)


def test_the_live_envelopes_are_in_percent_of_each_mvc():
    session = _session_with_mvcs([2e-4, 4e-4, 1e-4])
    del session.records["anterior_deltoid"]  # not recorded yet: not shown in % MVC
    x = wave(int(2 * RATE), [1e-4, 3e-4, 1e-4])  # triceps (ch 1) at 1e-4, biceps (ch 3) 1e-4
    t = 10.0 + np.arange(x.shape[0]) / RATE
    env, muscles = live_percent(t, x, RATE, session)
    assert muscles == ("biceps", "triceps")
    middle = env.values[5:-5]
    np.testing.assert_allclose(middle[:, 0], 0.5, rtol=0.05)
    np.testing.assert_allclose(middle[:, 1], 0.25, rtol=0.05)
    assert env.t_s[-1] <= 0.0
    assert env.t_s[0] >= -2.0


def test_the_live_envelopes_end_at_the_newest_sample_whatever_origin_each_read_had():
    """A Trigno stream's reads are stamped with the origin known at each read, which moves
    earlier as later blocks arrive (device.emg.trigno): the live view's stamps then span
    less than the samples, and the view drew its newest envelope in the future (a whole
    check at load 9: 0.34 s after now). Both live views stamp by the samples' count."""
    from ui.views.emg import live_emg_view

    session = _session_with_mvcs([2e-4, 4e-4, 1e-4])
    x = wave(int(2 * RATE), [1e-4, 3e-4, 1e-4])
    k = np.arange(x.shape[0]) / RATE
    # the first second read while the origin was 0.4 s later than the one known now
    t = 10.0 + k + np.where(k < 1.0, 0.4, 0.0)
    env, _ = live_percent(t, x, RATE, session)
    raw = live_emg_view(t, x, RATE)
    for times in (env.t_s, raw.t_s):
        assert times[-1] <= 0.0
        assert times[0] >= -2.0
        # the envelope's newest point is within one window of the newest sample
        assert times[-1] > -0.2


def test_the_live_view_names_the_channels_as_the_trial_file_will():
    """An LSL stream's labels name the trial file's EMG channels (the muscles); the live
    view said EMG1, EMG2 over the same signals."""
    from ui.views.emg import live_emg_view

    x = wave(int(2 * RATE), [1e-4, 3e-4])
    t = 10.0 + np.arange(x.shape[0]) / RATE
    assert live_emg_view(t, x, RATE, labels=("biceps", "triceps")).names == ("biceps",
                                                                            "triceps")
    assert live_emg_view(t, x, RATE, labels=("biceps", "biceps")).names == ("EMG1", "EMG2")
    assert live_emg_view(t, x, RATE).names == ("EMG1", "EMG2")


def test_the_live_view_draws_the_assigned_muscles_and_says_the_other_channels():
    """A base station's 16 channels, most of them empty sensors, were all drawn before any
    MVC: the live view draws the muscles the tab puts on channels, in µV until their MVCs,
    and says in one quiet line which channels stream on no muscle."""
    from ui.views.emg import live_emg_view

    levels = [1e-5 * (c + 1) for c in range(16)]  # channel c at (c+1) × 10 µV
    x = wave(int(2 * RATE), levels)
    t = 10.0 + np.arange(x.shape[0]) / RATE
    session = SessionMvcs("P1", 1, channels={"biceps": 2, "triceps": 0, "anterior_deltoid": 1})
    for view in (live_emg_view(t, x, RATE, session),
                 live_emg_view(t, x, RATE, assigned=dict(session.channels))):
        assert view.unit == "µV"
        assert view.names == ("biceps", "triceps", "anterior_deltoid")
        np.testing.assert_allclose(view.values[-1], np.array([30, 10, 20]) / 2 ** 0.5,
                                   rtol=0.1)
        assert view.aside == ("channels 4–16 streaming, not on a muscle: not drawn",)
    session.channels["triceps"] = 16  # a 17th channel: the source has none
    assert live_emg_view(t, x, RATE, session).aside == (
        "triceps brachii: its channel 17 is not in the source (channels 1 to 16)",
        "channels 1, 4–16 streaming, not on a muscle: not drawn")


def test_a_muscle_whose_mvc_is_flagged_is_not_read_in_percent_of_it():
    """The deltoid's MVC flagged (below the trial's activity: a trial stored after it was
    recorded) was still the live view's reference: the deltoid showed at about 100 % MVC
    while its row said to record it again. Only usable MVCs give % MVC; the others are
    said beside the key, with the flag, until recorded again."""
    from ui.views.emg import live_emg_view

    session = _session_with_mvcs([2e-4, 2e-4, 2e-4])
    x = wave(int(2 * RATE), [2e-4, 1e-4, 2e-4])  # each at (or half) its MVC
    t = 10.0 + np.arange(x.shape[0]) / RATE
    assert live_emg_view(t, x, RATE, session).names == ("biceps", "triceps",
                                                         "anterior_deltoid")
    flagged = dataclasses.replace(session.records["anterior_deltoid"].mvc, flags=(BELOW_TRIAL,))
    session.judged(flagged)
    view = live_emg_view(t, x, RATE, session)
    assert view.unit == "% MVC"
    assert view.names == ("biceps", "triceps")
    assert view.aside == ("anterior deltoid: not drawn, its MVC is lower than the trial's "
                          "activity: record it again",)
    session.judged(session.records["anterior_deltoid"].mvc)  # recorded again, ok
    assert live_emg_view(t, x, RATE, session).names[-1] == "anterior_deltoid"
    # every MVC flagged: nothing to read % MVC by, the muscles in µV
    for muscle in ("biceps", "triceps", "anterior_deltoid"):
        session.judged(dataclasses.replace(session.records[muscle].mvc, flags=(BELOW_TRIAL,)))
    view = live_emg_view(t, x, RATE, session)
    assert view.unit == "µV"
    assert view.names == ("biceps", "triceps", "anterior_deltoid")


def test_the_source_words():
    assert source_spec("trigno", " 192.168.1.20 ") == "trigno:192.168.1.20"
    assert source_spec("lsl", "Delsys EMG") == "lsl:Delsys EMG"
    assert source_spec("trigno", "lsl:emg") == "lsl:emg"
    assert source_spec("trigno", "usb:x") == "usb:x"  # refused by open_source, in words
    assert full_scale_of("trigno:h") == 0.011
    assert full_scale_of("lsl:emg") is None


def test_only_the_trials_own_samples_are_checked_against_the_mvc(plain_trial, tmp_path):
    """A live capture's margin before the trial may hold the MVC contraction itself (or a
    harder push): that is not the trial's activity."""
    origin = 5000.0
    path = shutil.copy(plain_trial, tmp_path / "live.h5")
    with edited(path) as f:
        f["summary"].attrs["wall_time_origin_monotonic_s"] = origin
        duration = f["timeseries/time"][-1]
    before = int(1.5 * RATE)
    n = before + int((duration + 0.5) * RATE)
    levels = np.full((n, 3), 0.6e-4)  # the reach: 30 % MVC
    levels[:before] = 2.4e-4  # the last push before the trial: 120 %
    captured = Captured(origin - 1.5 + np.arange(n) / RATE, wave(n, [1.0] * 3) * levels,
                        RATE, 0, "")
    session = _session_with_mvcs([2e-4, 2e-4, 2e-4])
    session.channels = {"biceps": 0, "triceps": 1, "anterior_deltoid": 2}
    _, checked = store_trial(path, captured, "trigno:x", session)
    assert all(mvc.ok for mvc in checked.values()), [m.reasons for m in checked.values()]
    assert read_emg(path).time_s[0] < -1.0  # the margin is stored all the same


def test_a_contraction_of_microvolts_read_as_volts_is_refused_not_said_ok():
    """An LSL stream of µV opened as lsl:amp@V: the window said 'MVC 69428193 µV: ok'."""
    x = wave(int(3 * RATE), [1e-4, 4e-4]) * 1e6
    t = np.arange(x.shape[0]) / RATE
    with pytest.raises(EmgImportError) as refused:
        contraction_mvc(t, x, RATE, "triceps", 1, settings=EmgSettings(), full_scale_V=None,
                        wanted_s=3.0, source="lsl:amp@V")
    message = str(refused.value)
    assert "(channel 2) reaches" in message
    assert "(in volts as lsl:amp@V gives them), more than surface EMG ever is (1 V)" in message
    assert message.endswith("(lsl:STREAM_NAME@uV), then record")


def test_the_live_view_says_at_once_when_the_source_gives_microvolts_as_volts():
    """Connected as lsl:amp@V, a µV stream drew envelopes of 10^8 µV and said nothing
    until an MVC was recorded of it; in volts it says nothing."""
    from ui.views.emg import live_emg_view

    x = wave(int(2 * RATE), [1e-4, 3e-4])
    t = 10.0 + np.arange(x.shape[0]) / RATE
    assert live_emg_view(t, x, RATE, labels=("biceps", "triceps")).problem == ""
    session = _session_with_mvcs([2e-4, 4e-4, 1e-4])
    for view, first in ((live_emg_view(t, x * 1e6, RATE, labels=("biceps", "triceps"),
                                       source="lsl:amp@V"), "biceps"),
                        (live_emg_view(t, np.column_stack([x, x[:, 0]]) * 1e6, RATE, session,
                                       source="lsl:amp@V"), "EMG1")):
        assert view.problem.startswith(f"{first} reaches ")
        assert "(in volts as lsl:amp@V gives them)" in view.problem
        assert "\n" not in view.problem


def test_the_source_s_channel_labels_name_the_stored_emg_and_its_mvcs(plain_trial, tmp_path):
    """Brief hT: an LSL stream that names its channels ("biceps_r", …) had them stored as
    EMG3, EMG1 … in the trial file, while the live view named them by the stream's labels
    (app.emg.importing.channel_names says the file keeps them so). The file and its MVCs
    now name them as the source does; a source that names none keeps EMG<k>."""
    origin = 5000.0
    path = shutil.copy(plain_trial, tmp_path / "labelled.h5")
    with edited(path) as f:
        f["summary"].attrs["wall_time_origin_monotonic_s"] = origin
        duration = f["timeseries/time"][-1]
    n = int((duration + 1.0) * RATE)
    labels = ("triceps_r", "deltoid_r", "biceps_r")
    captured = Captured(origin - 0.5 + np.arange(n) / RATE, wave(n, [1e-4, 3e-4, 1e-4]),
                        RATE, 0, "", labels)
    session = _session_with_mvcs([2e-4, 2e-4, 2e-4])
    for muscle, record in session.records.items():
        session.records[muscle] = dataclasses.replace(
            record, channel_name=labels[record.channel])
    store_trial(path, captured, "lsl:amp", session)
    emg = read_emg(path)
    assert emg.names == ("biceps_r", "triceps_r", "deltoid_r")
    assert emg.mvc["biceps"]["channel"] == "biceps_r"
    unnamed = _session_with_mvcs([2e-4, 2e-4, 2e-4])
    assert [m[2] for m in unnamed.measured()] == ["EMG3", "EMG1", "EMG2"]
