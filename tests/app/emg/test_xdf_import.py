"""`rehab emg import TRIAL recording.xdf`: a LabRecorder recording of the console's robot
stream, its markers and an EMG stream, all real pylsl streams recorded by the tests' small
LabRecorder (tests/xdf_recorder.py) and read by pyxdf, lands in the trial on its clock
within one EMG sample, in volts by the stream's declared units; a recording that does not
hold the trial is refused in one line."""

import shutil
import time
import uuid

import h5py
import numpy as np
import pylsl
import pytest

from app.emg.importing import EmgImportError, trial_time_from_monotonic
from app.emg.xdf import import_xdf
from app.trials.headless import save, simulate
from app.trials.reader import read_trial
from core.trial import THESIS_SUBJECT
from device.errors import DeviceError
from device.loop.messages import TrialMarker
from device.lsl.outlet import RobotStateOutlet
from device.recording.emgfile import read_emg
from device.recording.record import empty_records
from tests.app.cli.running import run
from tests.patience import HANG_S
from tests.trialfiles import edited
from tests.xdf_recorder import XdfRecorder

EMG_HZ = 1000.0


@pytest.fixture(scope="module")
def plain_trial(tmp_path_factory):
    path = tmp_path_factory.mktemp("trial") / "trial.h5"
    save(simulate(THESIS_SUBJECT.replace(repetitions=1), engine="python"), path)
    return path


@pytest.fixture(scope="module")
def other_trial(tmp_path_factory):
    """Another trial at the same settings: another patient's draw, another run of positions."""
    path = tmp_path_factory.mktemp("trial") / "other.h5"
    save(simulate(THESIS_SUBJECT.replace(repetitions=1), engine="python", seed=7), path)
    return path


def _live_trial(plain_trial, folder, origin, name="live.h5"):
    path = shutil.copy(plain_trial, folder / name)
    with edited(path) as f:  # as a live trial's recorder writes it (sealed again)
        f["summary"].attrs["wall_time_origin_monotonic_s"] = origin
    return path


def _emg_outlet(source, unit="microvolts", scaling=None, extra=(), kind=None):
    """Three EMG channels, then `extra` channels (label, type, unit) as an amplifier's app
    appends them; `kind` each EMG channel's declared type (none by default)."""
    info = pylsl.StreamInfo(f"emg-{source}", "EEG" if extra else "EMG", 3 + len(extra),
                            EMG_HZ, pylsl.cf_int16, source)
    channels = info.desc().append_child("channels")
    for label in ("biceps", "triceps", "deltoid"):
        channel = channels.append_child("channel")
        channel.append_child_value("label", label)
        if kind:
            channel.append_child_value("type", kind)
        if unit:
            channel.append_child_value("unit", unit)
        if scaling:
            channel.append_child_value("scaling_factor", scaling)
    for label, kind_, unit_ in extra:
        channels.append_child("channel").append_child_value("label", label) \
            .append_child_value("type", kind_).append_child_value("unit", unit_)
    return pylsl.StreamOutlet(info)


def _wait(condition, what, timeout=HANG_S):
    deadline = time.monotonic() + timeout
    while not condition():
        assert time.monotonic() < deadline, f"{what} did not happen"
        time.sleep(0.01)


def _record(tmp_path, trial_path, emg_start_s=0.5, unit="microvolts", with_robot=True,
            periods=None, scaling=None, console_ahead_s=0.0, emg_ahead_s=0.0, extra=(),
            kind=None, written=None):
    """Record the trial's ticks as the console's outlet publishes them, an int16 EMG
    stream of known samples at known stamps, and a marker; returns (xdf, stamps, samples),
    the stamps on the console's clock. The console's and the EMG computer's clocks run
    `console_ahead_s` and `emg_ahead_s` ahead of the recording computer's (the trial's
    clock origin is on the console's). `written`, a dict, gets the EMG stream's clock
    offsets as the recorder wrote them (tests.xdf_recorder.XdfRecorder.written)."""
    data = read_trial(trial_path)
    origin = float(data.summary["wall_time_origin_monotonic_s"])
    tag = uuid.uuid4().hex[:10]
    robot_source, emg_source = f"robot-{tag}", f"emg-{tag}"
    outlet = RobotStateOutlet(500.0, source_id=robot_source) if with_robot else None
    emg = _emg_outlet(emg_source, unit, scaling, extra, kind)
    sources = [emg_source] + ([robot_source, robot_source + "-events"] if with_robot else [])
    recorder = XdfRecorder(sources, {emg_source: emg_ahead_s, robot_source: console_ahead_s,
                                     robot_source + "-events": console_ahead_s})
    _wait(emg.have_consumers, "the recorder connecting")
    periods = np.full(3000, 1.0 / EMG_HZ) if periods is None else periods
    stamps = origin + emg_start_s + np.concatenate(([0.0], np.cumsum(periods[1:])))
    emg_clock = stamps - console_ahead_s + emg_ahead_s  # the same moments on the EMG's
    width = 3 + len(extra)
    samples = ((np.arange(3000 * width).reshape(3000, width) * 37) % 20001
               - 10000).astype(np.int16)
    samples[:, 3:] = -1  # a trigger channel: -1, and the code where one came
    samples[::500, 3:] = 7
    if with_robot:
        _wait(outlet.have_consumers, "the recorder connecting")
        records = empty_records(data.n_samples)
        for name in ("wall_time", "position", "force", "phase"):
            records[name] = data.channels[name]
        outlet.clock_started(0, origin)
        outlet.mark(TrialMarker("start", "trial started", {"file": trial_path.name}, 0, 0,
                                origin))
        for k in range(0, len(records), 250):
            outlet.push_records(records[k:k + 250], k)
    for k in range(0, 3000, 100):
        emg.push_chunk(samples[k:k + 100], timestamp=emg_clock[k:k + 100].tolist())
    # what is on its way to the recorder: every sample pushed, the marker (one at least)
    recorder.wait_for({emg_source: len(samples)} | (
        {robot_source: len(records), robot_source + "-events": 1} if with_robot else {}))
    path = recorder.stop(tmp_path / f"{tag}.xdf")
    if written is not None:
        written["emg"] = recorder.written[emg_source]
    return path, stamps, samples


def _landed(trial, xdf, stamps, samples):
    """(what import_xdf did, the trial's EMG) once it is checked that every sample landed,
    in volts, within one EMG sample of its moment on the trial's clock, the first at
    0.5 s."""
    done = import_xdf(trial, xdf)
    emg = read_emg(trial)
    np.testing.assert_array_equal(emg.samples, samples.astype(float) * 1e-6)
    expected = trial_time_from_monotonic(read_trial(trial), stamps)
    assert np.max(np.abs(emg.time_s - expected)) < 1.0 / EMG_HZ
    assert emg.time_s[0] == pytest.approx(0.5, abs=1.0 / EMG_HZ)
    return done, emg


def test_an_xdf_recording_lands_in_the_trial_within_one_emg_sample(plain_trial, tmp_path):
    trial = _live_trial(plain_trial, tmp_path, time.monotonic() - 30.0)
    xdf, stamps, samples = _record(tmp_path, trial)
    done, emg = _landed(trial, xdf, stamps, samples)
    assert done.names == ("biceps", "triceps", "deltoid")
    assert done.rate_hz == EMG_HZ
    assert any("placed through the rehab-robot stream" in note for note in done.notes)
    assert emg.attrs["source"] == "xdf"


@pytest.mark.parametrize(("console_ahead_s", "emg_ahead_s"), [
    (0.0, 1000.25), (-37.5, 0.0), (12.125, -3600.0625)])
def test_the_emg_of_a_computer_on_another_clock_lands_within_one_sample(
        plain_trial, tmp_path, console_ahead_s, emg_ahead_s):
    """The console, the EMG computer and the recording computer on three clocks: pyxdf's
    clock offsets and the robot stream's ticks put the EMG on the trial's clock."""
    trial = _live_trial(plain_trial, tmp_path, time.monotonic() - 30.0)
    xdf, stamps, samples = _record(tmp_path, trial, console_ahead_s=console_ahead_s,
                                   emg_ahead_s=emg_ahead_s)
    done, _ = _landed(trial, xdf, stamps, samples)
    said = float(done.notes[0].split("console clock = ")[1].split(" s")[0])
    assert said == pytest.approx(-console_ahead_s, abs=1e-3)  # less the offset liblsl measured


def test_the_clock_offsets_pyxdf_applied_are_kept_with_the_emg_sealed_and_shown(
        plain_trial, tmp_path, capsys):
    """pyxdf added LabRecorder's clock offsets to the EMG stream's stamps and the import
    kept no record of them (a live LSL capture keeps its own in /emg clock_offsets): each
    offset the recording holds for the EMG stream is now in the trial's /emg, at the
    trial time it was measured, in the sealed file, and `rehab emg show` says them."""
    console_ahead_s, emg_ahead_s = 12.125, -3600.0625
    trial = _live_trial(plain_trial, tmp_path, time.monotonic() - 30.0)
    written = {}
    xdf, stamps, samples = _record(tmp_path, trial, console_ahead_s=console_ahead_s,
                                   emg_ahead_s=emg_ahead_s, written=written)
    _, emg = _landed(trial, xdf, stamps, samples)
    known = written["emg"]
    assert len(known) == 2  # as the recorder opened the stream and as it stopped
    assert [offset for _, offset in emg.clock_offsets] == [offset for _, offset in known]
    # measured on the sender's clock at collection + offset on the recording computer's,
    # which the console's runs console_ahead_s ahead of
    when = trial_time_from_monotonic(read_trial(trial), [
        collected + offset + console_ahead_s for collected, offset in known])
    np.testing.assert_allclose([t for t, _ in emg.clock_offsets], when, atol=1e-3)
    assert "clock_offsets" in emg.attrs["clock"]
    with h5py.File(trial, "r+") as f:  # the file's seal covers them
        f["emg"].attrs["clock_offsets"] = "[[0.5, 1.0]]"
    with pytest.raises(DeviceError, match="does not match its seal"):
        read_emg(trial)
    again = _live_trial(plain_trial, tmp_path, read_trial(trial).summary[
        "wall_time_origin_monotonic_s"], name="again.h5")
    import_xdf(again, xdf)
    code, out, err = run(["emg", "show", str(again)], capsys)
    assert code == 0, err
    line = next(line for line in out.splitlines() if line.startswith("  clock: "))
    assert line.startswith("  clock: LabRecorder's clock offsets of the EMG stream, a line "
                           "through them added to the sender's stamps by pyxdf, ")
    assert line.endswith(" s (/emg clock_offsets)")
    for _, offset in known:  # one value, or the lowest and highest of them
        assert f"{offset:.6f}" in line


def test_a_raw_integer_stream_is_imported_in_volts_by_its_scaling_factor(plain_trial,
                                                                        tmp_path):
    """A BrainAmp's raw int16 stream (microvolts, scaling_factor 0.1) was imported ten times
    too large: the factor was not read."""
    trial = _live_trial(plain_trial, tmp_path, time.monotonic() - 30.0)
    xdf, _, samples = _record(tmp_path, trial, scaling="0.1")
    import_xdf(trial, xdf)
    np.testing.assert_allclose(read_emg(trial).samples, samples.astype(float) * 1e-7,
                               rtol=1e-12)


def test_a_brainamp_stream_is_imported_without_its_trigger_channel_with_one_note(
        plain_trial, tmp_path):
    """BrainAmpSeries' app appends `triggerStream` (type EEG, unit `code`) to its EEG-typed
    data stream: the whole stream was refused for that one channel."""
    trial = _live_trial(plain_trial, tmp_path, time.monotonic() - 30.0)
    xdf, _, samples = _record(tmp_path, trial, kind="EEG", scaling="0.1",
                              extra=[("triggerStream", "EEG", "code")])
    done = import_xdf(trial, xdf, stream=f"emg-emg-{xdf.stem}")  # the recorder's tag
    emg = read_emg(trial)
    np.testing.assert_allclose(emg.samples, samples[:, :3].astype(float) * 1e-7, rtol=1e-12)
    assert done.names == ("biceps", "triceps", "deltoid")
    (left_out,) = [n for n in done.notes if "triggerStream" in n]
    assert "unit 'code'" in left_out


def test_a_liveamp_stream_with_its_accelerometer_is_imported_with_one_note(plain_trial,
                                                                            tmp_path):
    """The LiveAmp app streams its accelerometer as it ships (`useACC=true`): such a
    recording was refused for ACC_X in milliGs."""
    trial = _live_trial(plain_trial, tmp_path, time.monotonic() - 30.0)
    xdf, _, samples = _record(tmp_path, trial, extra=[
        ("ACC_X", "ACC", "milliGs"), ("SampleCounter", "SampleCounter", ""),
        ("STESync", "SyncPulse", "integer")])
    done = import_xdf(trial, xdf, stream=f"emg-emg-{xdf.stem}")
    np.testing.assert_allclose(read_emg(trial).samples, samples[:, :3].astype(float) * 1e-6,
                               rtol=1e-12)
    (left_out,) = [n for n in done.notes if "not EMG" in n]
    assert "ACC_X, an accelerometer (type 'ACC')" in left_out
    assert "SampleCounter, a sample counter" in left_out
    assert "STESync, a sync pulse" in left_out


def test_a_channel_that_is_neither_emg_nor_declared_otherwise_still_refuses_the_stream(
        plain_trial, tmp_path):
    trial = _live_trial(plain_trial, tmp_path, time.monotonic() - 30.0)
    xdf, _, _ = _record(tmp_path, trial, extra=[("ACC_X", "MISC", "milliGs")])
    with pytest.raises(EmgImportError, match=r"gives ACC_X in 'milliGs', not a voltage") \
            as refused:
        import_xdf(trial, xdf, stream=f"emg-emg-{xdf.stem}")
    assert "\n" not in str(refused.value)


def test_a_recording_of_another_trial_or_without_the_robot_is_refused_in_one_line(
        plain_trial, other_trial, tmp_path):
    trial = _live_trial(plain_trial, tmp_path, time.monotonic() - 30.0)
    other = _live_trial(other_trial, tmp_path, time.monotonic() - 90.0, "other.h5")
    xdf, _, _ = _record(tmp_path, other)
    with pytest.raises(EmgImportError, match=r"its rehab-robot stream does not hold trial "
                                             r"live\.h5 \(at best \d+ % of its ticks") as refused:
        import_xdf(trial, xdf)
    assert "\n" not in str(refused.value)
    alone, _, _ = _record(tmp_path, trial, with_robot=False)
    with pytest.raises(EmgImportError, match="has no rehab-robot stream"):
        import_xdf(trial, alone)


def test_an_emg_stream_without_units_needs_one_given(plain_trial, tmp_path, capsys):
    trial = _live_trial(plain_trial, tmp_path, time.monotonic() - 30.0)
    xdf, _, samples = _record(tmp_path, trial, unit=None)
    with pytest.raises(EmgImportError, match=r"does not say the unit of biceps, not a "
                                             r"voltage: give it with --unit"):
        import_xdf(trial, xdf)
    code, out, err = run(["emg", "import", str(trial), str(xdf), "--unit", "uV",
                          "--muscles", "biceps_brachii,triceps_brachii,anterior_deltoid"],
                         capsys)
    assert code == 0, err
    assert "stored 3 EMG channels (biceps_brachii, triceps_brachii, anterior_deltoid) at " \
           "1000 Hz" in out
    np.testing.assert_array_equal(read_emg(trial).samples, samples.astype(float) * 1e-6)
    code, _, err = run(["emg", "import", str(trial), str(xdf), "--offset", "1", "--replace"],
                       capsys)
    assert code == 2
    assert "--offset is for exported files" in err


def test_a_damaged_recording_is_refused_in_one_line_or_noted_never_silent(plain_trial,
                                                                          tmp_path):
    """pyxdf raised xml.etree's ParseError on a damaged stream header (a traceback), and
    skipped a damaged chunk with a line on stderr only (silent to the researcher)."""
    trial = _live_trial(plain_trial, tmp_path, time.monotonic() - 30.0)
    xdf, _, samples = _record(tmp_path, trial)
    data = xdf.read_bytes()
    header = data.index(b"<name>")
    broken = tmp_path / "broken.xdf"
    broken.write_bytes(data[:header + 1] + b"#" + data[header + 2:])
    with pytest.raises(EmgImportError, match=r"broken\.xdf: cannot be read \(ParseError") \
            as refused:
        import_xdf(trial, broken)
    assert "\n" not in str(refused.value)
    cut = tmp_path / "cut.xdf"
    cut.write_bytes(data[:-5])  # the last stream's footer cut short
    done = import_xdf(trial, cut)
    assert any(note.startswith("the recording is damaged: pyxdf skipped what it could not "
                               "read") for note in done.notes), done.notes
    np.testing.assert_array_equal(read_emg(trial).samples, samples.astype(float) * 1e-6)


def test_a_stream_that_stopped_in_the_recording_is_noted_and_one_at_another_rate_refused(
        plain_trial, tmp_path):
    """LabRecorder keeps recording a restarted EMG sender into the same stream: a hole,
    then perhaps samples at another rate under the rate the header declares. Both were
    stored as if the stream had run evenly, with nothing said."""
    trial = _live_trial(plain_trial, tmp_path, time.monotonic() - 30.0)
    periods = np.full(3000, 1.0 / EMG_HZ)
    periods[1500] = 2.0
    xdf, _, _ = _record(tmp_path, trial, periods=periods)
    done = import_xdf(trial, xdf)
    said = [n for n in done.notes if "stopped" in n]
    assert len(said) == 1
    assert "stopped for 2.0 s at trial time 2.0 s (1999 samples missing)" in said[0]
    assert said[0] in read_emg(trial).notes  # in the file with the EMG

    other = _live_trial(plain_trial, tmp_path, time.monotonic() - 30.0, name="rate.h5")
    periods[1501:] = 2.0 / EMG_HZ
    xdf, _, _ = _record(tmp_path, other, periods=periods)
    with pytest.raises(EmgImportError, match=r"ran at about 500 Hz from trial time 4.0 s, "
                                             r"not the 1000 Hz it declares"):
        import_xdf(other, xdf)


@pytest.mark.parametrize(("declared", "given", "said"), [
    (None, "V", "in 'V' as given with --unit"),
    ("mV", None, "in 'mV' as the stream declares")])
def test_microvolts_given_or_declared_as_larger_units_are_refused(plain_trial, tmp_path,
                                                                  declared, given, said):
    """An int16 stream of µV counts (up to ±10000) imported in V or in mV, the unit a lab
    gave or its amplifier's app declared wrongly: stored as up to 10 kV before."""
    trial = _live_trial(plain_trial, tmp_path, time.monotonic() - 30.0)
    xdf, _, _ = _record(tmp_path, trial, unit=declared)
    with pytest.raises(EmgImportError) as refused:
        import_xdf(trial, xdf, unit=given)
    message = str(refused.value)
    assert "\n" not in message
    assert f"({said}), more than surface EMG ever is (1 V)" in message
    assert "with --unit (V, mV or uV)" in message
