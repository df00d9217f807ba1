"""Live EMG beside a trial: a capture from the fake Trigno Control Utility and from an LSL
stream, stored in the trial file on the trial's clock; a source lost mid-trial keeps what
it had and says why."""

import shutil
import time
import uuid

import numpy as np
import pylsl
import pytest

from app.emg.importing import EmgImportError, import_capture
from app.trials.headless import save, simulate
from core.trial import THESIS_SUBJECT
from device.emg.capture import EmgCapture
from device.emg.trigno import TrignoClient
from device.lsl.inlet import LslEmgInlet
from device.recording.emgfile import read_emg
from tests.app.cli.running import run
from tests.fake_trigno import fake_trigno
from tests.trialfiles import edited

fake = fake_trigno()


@pytest.fixture(scope="module")
def plain_trial(tmp_path_factory):
    path = tmp_path_factory.mktemp("trial") / "trial.h5"
    save(simulate(THESIS_SUBJECT.replace(repetitions=1), engine="python"), path)
    return path


def _live_trial(plain_trial, tmp_path, origin):
    path = shutil.copy(plain_trial, tmp_path / "live.h5")
    with edited(path) as f:  # as a live trial's recorder writes it
        f["summary"].attrs["wall_time_origin_monotonic_s"] = origin
    return path


def _lsl_emg_outlet(name, labels, unit, channel_format):
    """An EMG outlet at 2 kHz that declares its channels as EMG software does: label and
    unit (the unit decides the volts)."""
    info = pylsl.StreamInfo(name, "EMG", len(labels), 2000.0, channel_format, name)
    described = info.desc().append_child("channels")
    for label in labels:
        channel = described.append_child("channel")
        channel.append_child_value("label", label)
        channel.append_child_value("unit", unit)
    return pylsl.StreamOutlet(info)


def _wait_for_consumers(outlet, timeout=10.0):
    deadline = time.monotonic() + timeout
    while not outlet.have_consumers():
        assert time.monotonic() < deadline, "the inlet did not connect"
        time.sleep(0.01)


def _capture_until(capture, n, timeout=20.0):
    deadline = time.monotonic() + timeout
    while capture.running and capture.latest()[0].size < n:
        assert time.monotonic() < deadline, "no EMG arrived"
        time.sleep(0.02)


def test_a_trigno_capture_lands_in_the_trial_on_its_clock(plain_trial, tmp_path):
    origin = time.monotonic()
    with fake.FakeTrignoServer() as server:
        client = TrignoClient("127.0.0.1", command_port=server.command_port,
                              data_port=server.data_port).open()
        client.start()
        capture = EmgCapture(client, channels=[0, 1, 2]).start()
        _capture_until(capture, 800)
        captured = capture.stop()
    assert captured.error == ""
    assert captured.missing == 0
    trial = _live_trial(plain_trial, tmp_path, origin)
    done = import_capture(trial, captured, names=("EMG1", "EMG2", "EMG3"),
                          muscles=["biceps", "triceps", "anterior_deltoid"], source="trigno-tcp")
    emg = read_emg(trial)
    n = emg.samples.shape[0]
    np.testing.assert_array_equal(emg.samples,
                                  fake.default_signal(np.arange(n))[:, :3].astype(float))
    assert emg.rate_hz == pytest.approx(26 / 0.0135)
    # captured after the origin: trial time 0 …, within the few seconds the test took
    assert 0.0 <= emg.time_s[0] < 10.0
    np.testing.assert_allclose(np.diff(emg.time_s), 0.0135 / 26, rtol=1e-6)
    assert "wall_time_origin_monotonic_s" in emg.attrs["clock"]
    assert done.muscles == ("biceps", "triceps", "anterior_deltoid")


def test_an_lsl_capture_lands_in_the_trial(plain_trial, tmp_path):
    name = f"test-{uuid.uuid4().hex[:12]}"
    outlet = _lsl_emg_outlet(name, ("a", "b", "c", "d"), "V", pylsl.cf_float32)
    inlet = LslEmgInlet(name, channels=4, rate_hz=2000.0, timeout_s=5.0).open(5.0)
    _wait_for_consumers(outlet)
    origin = time.monotonic()
    capture = EmgCapture(inlet).start()
    sent = np.arange(4000 * 4, dtype=np.float32).reshape(4000, 4) * 1e-7
    stamps = origin + 1.0 + np.arange(4000) / 2000.0
    outlet.push_chunk(sent, timestamp=stamps.tolist())
    _capture_until(capture, 4000)
    captured = capture.stop()
    trial = _live_trial(plain_trial, tmp_path, origin)
    import_capture(trial, captured, names=("a", "b", "c", "d"), source=f"lsl:{name}")
    emg = read_emg(trial)
    np.testing.assert_allclose(emg.samples, sent.astype(float))
    # the sender's stamps, mapped: 1 s after the origin is trial time 1 s
    np.testing.assert_allclose(emg.time_s, 1.0 + np.arange(4000) / 2000.0, atol=5e-3)


def test_an_lsl_capture_s_trial_file_says_which_clock_offsets_were_added(plain_trial,
                                                                          tmp_path, capsys):
    """A sender on another computer stamps by its own clock; liblsl's offset between it and
    this machine's was added to every stamp, changed as liblsl re-estimated it, and the
    trial file said nothing of it (docs/data-format.md only described it). /emg
    `clock_offsets` now keeps each offset added, from the trial time it began. The sender's
    clock is put 1000 s behind by its stamps, and liblsl's estimate (1 ms or less apart on
    one machine) is given as that computer's would be: 1000 s, then 4 ms more."""
    name = f"test-{uuid.uuid4().hex[:12]}"
    outlet = _lsl_emg_outlet(name, ("a", "b"), "V", pylsl.cf_float32)
    inlet = LslEmgInlet(name, channels=2, rate_hz=2000.0, timeout_s=5.0).open(5.0)
    _wait_for_consumers(outlet)
    estimate = [1000.0]
    inlet._inlet.time_correction = lambda timeout: estimate[0]
    origin = time.monotonic()
    capture = EmgCapture(inlet).start()
    sent = np.arange(4000 * 2, dtype=np.float32).reshape(4000, 2) * 1e-7
    theirs = origin + 1.0 - 1000.0 + np.arange(4000) / 2000.0  # the sender's clock
    outlet.push_chunk(sent[:2000], timestamp=theirs[:2000].tolist())
    _capture_until(capture, 2000)
    estimate[0] = 1000.004  # liblsl's next estimate: the clocks drifted 4 ms apart
    outlet.push_chunk(sent[2000:], timestamp=theirs[2000:].tolist())
    _capture_until(capture, 4000)
    captured = capture.stop()
    trial = _live_trial(plain_trial, tmp_path, origin)
    import_capture(trial, captured, names=("a", "b"), source=f"lsl:{name}")
    emg = read_emg(trial)
    first = 1.0 + np.arange(4000) / 2000.0
    first[2000:] += 0.004
    np.testing.assert_allclose(emg.time_s, first, atol=5e-3)
    (start, offset), (changed, later) = emg.clock_offsets
    assert (offset, later) == (1000.0, 1000.004)
    assert start == emg.time_s[0]
    assert changed == emg.time_s[2000]
    assert "clock_offsets" in emg.attrs["clock"]
    code, out, err = run(["emg", "show", str(trial)], capsys)
    assert code == 0, err
    assert "clock: liblsl's clock offset added to the LSL sender's stamps, 2 estimates " \
           "from 1000.000000 to 1000.004000 s (/emg clock_offsets)" in out


def test_an_lsl_capture_whose_chunks_overlap_lands_in_a_readable_trial(plain_trial, tmp_path):
    """EMG software that pushes chunks without stamps gets liblsl's (the last sample at the
    push, the others back at the nominal rate): a push 3 ms early overlaps the chunk
    before. Stored as they came, the trial's /emg read back as damaged ('/emg/time goes
    from … it only ever increases'), the EMG of a live trial lost."""
    name = f"test-{uuid.uuid4().hex[:12]}"
    outlet = _lsl_emg_outlet(name, ("a", "b"), "V", pylsl.cf_float32)
    inlet = LslEmgInlet(name, channels=2, rate_hz=2000.0, timeout_s=5.0).open(5.0)
    _wait_for_consumers(outlet)
    origin = time.monotonic()
    capture = EmgCapture(inlet).start()
    sent = np.arange(2000 * 2, dtype=np.float32).reshape(2000, 2) * 1e-7
    stamps = origin + 1.0 + np.arange(2000) / 2000.0
    stamps[500:] -= 0.003
    for k in range(0, 2000, 500):
        outlet.push_chunk(sent[k:k + 500], timestamp=stamps[k:k + 500].tolist())
    _capture_until(capture, 2000)
    captured = capture.stop()
    trial = _live_trial(plain_trial, tmp_path, origin)
    import_capture(trial, captured, names=("a", "b"), source=f"lsl:{name}")
    emg = read_emg(trial)
    np.testing.assert_allclose(emg.samples, sent.astype(float))
    assert (np.diff(emg.time_s) > 0).all()
    np.testing.assert_allclose(emg.time_s, stamps - origin, atol=5e-3)


def test_emg_show_names_a_live_source_once(plain_trial, tmp_path, capsys):
    """A live capture's source is also its 'source file': `rehab emg show` printed
    '(lsl:amp, lsl:amp)'."""
    from app.cli.main import main
    from device.emg.capture import Captured

    trial = _live_trial(plain_trial, tmp_path, 100.0)
    samples = np.random.default_rng(0).normal(0.0, 1e-4, (2000, 2))
    captured = Captured(101.0 + np.arange(2000) / 2000.0, samples, 2000.0, 0, "", ("a", "b"),
                        ())
    import_capture(trial, captured, names=("a", "b"), source="lsl:amp")
    assert main(["emg", "show", str(trial)]) == 0
    first = capsys.readouterr().out.splitlines()[0]
    assert first.endswith(" s (lsl:amp)"), first


def test_a_source_lost_mid_trial_keeps_what_it_had(plain_trial, tmp_path):
    origin = time.monotonic()
    with fake.FakeTrignoServer() as server:
        server.fake_drop_data_after = 260
        client = TrignoClient("127.0.0.1", command_port=server.command_port,
                              data_port=server.data_port).open()
        client.start()
        capture = EmgCapture(client).start()
        deadline = time.monotonic() + 20
        while capture.running:
            assert time.monotonic() < deadline
            time.sleep(0.02)
        captured = capture.stop()
    assert "closed the EMG data connection" in captured.error
    assert captured.samples.shape == (260, 16)
    trial = _live_trial(plain_trial, tmp_path, origin)
    done = import_capture(trial, captured, names=tuple(f"EMG{i}" for i in range(1, 17)),
                          source="trigno-tcp")
    assert any("ended early" in n for n in done.notes)
    # kept with the EMG in the file, not only said
    assert read_emg(trial).notes == done.notes
    assert any("ended early" in n for n in read_emg(trial).notes)
    empty = EmgCapture(client).stop()
    with pytest.raises(EmgImportError, match="no EMG was captured"):
        import_capture(trial, empty, names=(), source="trigno-tcp", replace=True)


class _SmallReads:
    """A source of 10 samples a read at 2 kHz (200 reads a second of its stamps), given as
    fast as it is read, 8 s of them, then nothing."""

    rate_hz = 2000.0

    def __init__(self) -> None:
        self.sent = 0

    def read(self, timeout_s=0.1):
        if self.sent >= 16000:
            time.sleep(0.005)
            return np.empty(0), np.empty((0, 1))
        k, self.sent = self.sent, self.sent + 10
        return 100.0 + np.arange(k, self.sent) / self.rate_hz, np.zeros((10, 1))

    def close(self) -> None:
        pass


def test_the_live_seconds_are_whole_from_a_source_of_many_small_reads():
    """The live view's last 5 s were the capture's 250 newest reads: a Trigno base station's
    came about 130 a second, and the EMG tab's live plot showed 1.3-2 s."""
    capture = EmgCapture(_SmallReads(), latest_s=5.0, stall_s=3600.0).start()
    try:
        deadline = time.monotonic() + 60.0
        while (capture.last_stamp_s or 0.0) < 100.0 + 15999 / 2000.0:
            assert time.monotonic() < deadline, "the source's reads did not all arrive"
            time.sleep(0.01)
        t, x = capture.latest()
    finally:
        capture.stop()
    assert t[-1] == pytest.approx(100.0 + 15999 / 2000.0)
    assert t[-1] - t[0] == pytest.approx(5.0, abs=1e-3)
    assert x.shape == (t.size, 1)


def test_a_capture_forgets_what_came_before_and_keeps_its_clock():
    """A source streaming across a session keeps only what the next trial may need; the
    samples kept keep their stamps on the even Trigno clock and their values."""
    with fake.FakeTrignoServer() as server:
        client = TrignoClient("127.0.0.1", command_port=server.command_port,
                              data_port=server.data_port).open()
        client.start()
        # latest() over the whole capture, so sample 600 counts from the first whatever
        # the machine's load let arrive meanwhile (over its last 5 s, a slow test forgot
        # 3,606 samples: everything before the last 5 s as well)
        capture = EmgCapture(client, latest_s=3600.0).start()
        try:  # the source closed whatever happens (a socket left open failed a later test)
            _capture_until(capture, 1200)
            middle = capture.latest()[0][600]
            dropped = capture.forget_before(middle)
            _capture_until(capture, 1200)
        finally:
            captured = capture.stop()
    assert 0 < dropped <= 600
    assert captured.error == ""
    k = dropped + np.arange(captured.samples.shape[0])
    np.testing.assert_array_equal(captured.samples, fake.default_signal(k).astype(float))
    np.testing.assert_allclose(captured.stamps_s, client.origin_s + k / client.rate_hz,
                               rtol=0, atol=1e-9)
    assert captured.stamps_s[0] <= middle
    assert captured.missing == 0


def test_an_lsl_source_without_units_is_refused_or_read_in_the_unit_given():
    from app.emg.live import open_source
    from device.lsl.library import LslError

    name = f"test-{uuid.uuid4().hex[:12]}"
    outlet = pylsl.StreamOutlet(pylsl.StreamInfo(name, "EMG", 2, 1000.0, pylsl.cf_int16, name))
    with pytest.raises(LslError, match=r"does not say the unit .* \(lsl:NAME@uV\)"):
        open_source(f"lsl:{name}", timeout_s=5.0)
    with pytest.raises(EmgImportError, match="lsl:STREAM_NAME@UNIT"):
        open_source(f"lsl:{name}@", timeout_s=5.0)
    source, label = open_source(f"lsl:{name}@uV", timeout_s=5.0)
    assert label == f"lsl:{name}"
    deadline = time.monotonic() + 10
    while not outlet.have_consumers():
        assert time.monotonic() < deadline
        time.sleep(0.01)
    outlet.push_chunk(np.array([[250, -1000]] * 5, dtype=np.int16))
    got = np.empty((0, 2))
    while got.shape[0] < 5:
        assert time.monotonic() < deadline
        got = np.vstack((got, source.read(0.2)[1]))
    np.testing.assert_array_equal(got[0], [250e-6, -1000e-6])
    source.close()


def test_a_live_lsl_capture_keeps_the_muscles_its_stream_names(plain_trial, tmp_path):
    """The stream's labels (LabRecorder's and the EMG software's channel names: the
    muscles) name the trial's EMG channels; they were stored as EMG1…"""
    from app.emg.importing import store_live_capture

    name = f"test-{uuid.uuid4().hex[:12]}"
    outlet = _lsl_emg_outlet(name, ("biceps", "triceps"), "uV", pylsl.cf_int16)
    inlet = LslEmgInlet(name, timeout_s=5.0).open(5.0)
    _wait_for_consumers(outlet)
    origin = time.monotonic()
    capture = EmgCapture(inlet).start()
    stamps = origin + 0.5 + np.arange(2000) / 2000.0
    outlet.push_chunk(np.full((2000, 2), 150, dtype=np.int16), timestamp=stamps.tolist())
    _capture_until(capture, 2000)
    captured = capture.stop()
    assert captured.labels == ("biceps", "triceps")
    trial = _live_trial(plain_trial, tmp_path, origin)
    done = store_live_capture(trial, captured, f"lsl:{name}")
    assert done.names == ("biceps", "triceps")
    emg = read_emg(trial)
    assert emg.names == ("biceps", "triceps")
    np.testing.assert_array_equal(emg.samples[:5], np.full((5, 2), 150e-6))


class _Quiet:
    """A source that gives `chunks` of samples, then nothing, on a clock that each read
    moves on by its timeout (as a read waiting for data does)."""

    rate_hz = 1000.0

    def __init__(self, chunks):
        self.chunks, self.now = list(chunks), 100.0

    def clock(self):
        return self.now

    def read(self, timeout_s=0.1):
        self.now += timeout_s
        if self.chunks:
            stamps = self.chunks.pop(0)
            return stamps, np.ones((stamps.size, 2))
        return np.empty(0), np.empty((0, 2))

    def close(self):
        pass


def _ended(capture):
    deadline = time.monotonic() + 20.0
    while capture.running:
        assert time.monotonic() < deadline, "the capture did not end"
        time.sleep(0.01)
    return capture.stop()


def test_a_source_that_goes_quiet_ends_the_capture_in_one_line_keeping_what_came():
    """An LSL sender that stops raises nothing (liblsl waits to recover it): the capture
    went on 'running' with nothing said, and the window never said the EMG had stopped."""
    source = _Quiet([100.0 + np.arange(50) / 1000.0])
    captured = _ended(EmgCapture(source, stall_s=1.0, clock=source.clock).start())
    assert captured.error.startswith("no EMG came for 1.")
    assert "stopped streaming" in captured.error
    assert captured.samples.shape == (50, 2)


def test_a_source_that_comes_back_after_a_gap_ends_the_capture_before_its_new_samples():
    """A restarted LSL sender (perhaps at another rate) came back under the rate first
    declared, after a hole: stored as if nothing had happened."""
    before = 100.0 + np.arange(50) / 1000.0
    source = _Quiet([before, before[-1] + 1.5 + np.arange(50) / 500.0])
    captured = _ended(EmgCapture(source, stall_s=1.0, clock=source.clock).start())
    assert "jumped 1.5 s ahead" in captured.error
    np.testing.assert_array_equal(captured.stamps_s, before)


def test_an_lsl_stream_whose_sender_stops_ends_the_capture():
    """The real thing: a sender with a source id (liblsl would wait to recover it) goes
    away; the capture ends with one line and keeps the samples it had."""
    name = f"test-{uuid.uuid4().hex[:12]}"
    outlet = _lsl_emg_outlet(name, ("biceps", "triceps"), "uV", pylsl.cf_int16)
    inlet = LslEmgInlet(name, timeout_s=5.0).open(5.0)
    _wait_for_consumers(outlet)
    capture = EmgCapture(inlet).start()
    outlet.push_chunk(np.full((400, 2), 150, dtype=np.int16))
    _capture_until(capture, 400)
    del outlet
    captured = _ended(capture)
    assert "stopped streaming" in captured.error
    assert captured.samples.shape == (400, 2)


def test_what_the_source_said_of_itself_is_kept_with_the_trial_s_emg(plain_trial, tmp_path):
    """An LSL stream's trigger channel left out (device.lsl.inlet's `notes`) was said on the
    EMG tab and by `rehab emg record`, but a live trial's /emg did not keep it: a reader of
    the file could not tell a channel had been left out."""
    left_out = "triggerStream, a trigger channel (unit 'code'), left out"

    class Source:
        rate_hz = 1000.0
        labels = ("biceps", "triceps")
        notes = (left_out,)

        def __init__(self):
            self.sent = False

        def read(self, timeout_s=0.1):
            if self.sent:
                time.sleep(timeout_s)
                return np.empty(0), np.empty((0, 2))
            self.sent = True
            stamps = time.monotonic() + np.arange(500) / 1000.0
            return stamps, np.ones((500, 2)) * 1e-5

        def close(self):
            pass

    origin = time.monotonic()
    capture = EmgCapture(Source()).start()
    _capture_until(capture, 500)
    captured = capture.stop()
    assert captured.notes == (left_out,)
    trial = _live_trial(plain_trial, tmp_path, origin)
    done = import_capture(trial, captured, names=captured.labels, source="lsl:amp")
    assert left_out in done.notes
    assert left_out in read_emg(trial).notes



def test_stamps_that_go_back_are_kept_in_order_and_said(plain_trial, tmp_path):
    """Seen in the window (brief hT): an LSL sender that stamps each chunk as it pushes it
    put a chunk's first stamp 2 ms before the last chunk's last; the trial stored the EMG
    as it came and its reader then refused the trial's whole EMG as damaged ("/emg/time
    goes from -1.8934 to -1.8954 s at sample 99; it only ever increases"). The capture
    now keeps the samples in the order they came, each stamp after the one before, and
    says so with the EMG."""
    first = 100.0 + np.arange(99) / 1000.0
    late = first[-1] - 0.002 + np.arange(1, 51) / 1000.0  # back-dated 2 ms
    source = _Quiet([first, late])
    captured = _ended(EmgCapture(source, stall_s=1.0, clock=source.clock).start())
    assert (np.diff(captured.stamps_s) > 0).all()
    np.testing.assert_array_equal(captured.stamps_s[:99], first)
    np.testing.assert_array_equal(captured.stamps_s[-48:], late[-48:])  # past the overlap
    (said,) = [n for n in captured.notes if "stamps" in n]
    assert said.startswith("2 samples' stamps were not after the sample before (by up to 1.0")
    path = _live_trial(plain_trial, tmp_path, 100.0)
    import_capture(path, captured, names=("a", "b"), source="lsl:amp")
    stored = read_emg(path)  # refused as damaged before
    assert said in stored.notes
