"""Reading trial files: round trips, live and crashed recordings, and damaged files."""

import inspect
import json
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import h5py
import numpy as np
import pytest

from app.errors import AppError, TrialFileError
from app.trials.checks import CODES
from app.trials.opening import UNSEALED_OLDER
from app.trials.reader import read_trial
from core.trial import THESIS_SUBJECT
from device.recording.record import CHANNELS, RECORD_DTYPE, Channel, extend_channels
from device.recording.trialfile import FORMAT_VERSION, SubjectInfo, write_trial
from tests.trialfiles import as_format_1, ramp_records

ROOT = Path(__file__).resolve().parents[3]
PERIOD_S = 0.002
PARAMETERS = THESIS_SUBJECT.replace(shape="circle", radius_m=0.07, controller="ctpid")
SUBJECT = SubjectInfo("S-07", 68.5, 0.29, 0.27, "left")
ROBOT = {"name": "thesis robot", "links_m": [0.1, 0.31, 0.31, 0.375]}
EVENTS = [
    {"time_s": 0.0, "tick": 0, "kind": "start", "message": "trial started", "values": {}},
    {"time_s": 0.5, "tick": 250, "kind": "fault", "message": "speed limit",
     "values": {"speed_m_s": 0.9, "limit_m_s": 0.8}},
    {"time_s": 0.9, "tick": 450, "kind": "stop", "message": "therapist stopped",
     "values": {"by": "therapist"}},
]


def random_records(n, dtype, seed):
    rng = np.random.default_rng(seed)
    records = np.zeros(n, dtype=dtype)
    for name in dtype.names:
        field = records[name]
        if field.dtype.kind == "f":
            records[name] = rng.normal(0.0, 3.0, field.shape).astype(field.dtype)
        else:
            records[name] = rng.integers(0, np.iinfo(field.dtype).max, field.shape,
                                         endpoint=True)
    for name, allowed in CODES.items():  # codes hold codes (app.trials.checks)
        if name in dtype.names:
            records[name] = rng.choice(sorted(allowed), n)
    if "assistance_level" in dtype.names:
        records["assistance_level"] = rng.uniform(0.0, 1.0, n)
    records["tick"] = np.arange(n)
    records["time"] = np.arange(n) * PERIOD_S
    return records


def save(path, records, channels=CHANNELS, **options):
    options = {"parameters": PARAMETERS, "subject": SUBJECT, "robot": ROBOT,
               "backend": "simulator", "sample_period_s": PERIOD_S, "channels": channels,
               **options}
    return write_trial(path, records, **options)


def test_round_trip_of_every_channel_and_all_metadata(tmp_path):
    records = random_records(1234, RECORD_DTYPE, seed=5)
    path = save(tmp_path / "trial.h5", records, events=EVENTS, status="stopped_early",
                metrics={"rms_error_m": 0.004, "mean_force_N": 3.5},
                summary={"stopped_by": "therapist"})
    trial = read_trial(path)

    assert list(trial.channels) == [c.name for c in CHANNELS]
    for c in CHANNELS:
        np.testing.assert_array_equal(trial.channels[c.name], records[c.name])
        assert trial.channels[c.name].dtype == np.dtype(c.dtype)
        assert trial.units[c.name] == c.units
        assert trial.frames[c.name] == c.frame
        assert trial.descriptions[c.name] == c.description
    np.testing.assert_array_equal(trial.time, records["time"])
    assert trial.n_samples == 1234
    assert trial.parameters == PARAMETERS
    assert trial.subject == SUBJECT
    assert trial.robot == ROBOT
    assert trial.backend == "simulator"
    assert trial.events == EVENTS
    assert trial.metrics == {"rms_error_m": 0.004, "mean_force_N": 3.5}
    assert trial.summary["n_samples"] == 1234
    assert trial.summary["stopped_by"] == "therapist"
    assert trial.status == "stopped_early"
    assert trial.closed
    assert trial.sample_period_s == PERIOD_S
    assert trial.format_version == FORMAT_VERSION
    assert trial.attrs["format"] == "rehab-console-trial"
    assert trial.path == path
    assert trial.notes == ()
    with pytest.raises(ValueError, match="read-only"):
        trial.channels["force"][0, 0] = 1.0


def test_extended_channels_round_trip(tmp_path):
    emg = Channel("emg", 4, "f4", "V", "none", "surface EMG, four muscles")
    channels, dtype = extend_channels((emg,))
    records = random_records(300, dtype, seed=6)
    trial = read_trial(save(tmp_path / "emg.h5", records, channels))
    assert trial.channels["emg"].shape == (300, 4)
    np.testing.assert_array_equal(trial.channels["emg"], records["emg"])
    assert trial.units["emg"] == "V"
    assert list(trial.channels)[-1] == "emg"


WRITER = textwrap.dedent("""
    import sys
    from core.trial import THESIS_SUBJECT
    from device.recording.record import RECORD_DTYPE
    from device.recording.trialfile import SubjectInfo, TrialFileWriter
    writer = TrialFileWriter(sys.argv[1], parameters=THESIS_SUBJECT,
                             subject=SubjectInfo.from_parameters("P-9", THESIS_SUBJECT),
                             robot={"name": "sim"}, backend="simulator", sample_period_s=0.002,
                             flush_interval_s=None)
    n = 0
    for line in sys.stdin:
        command = line.split()
        if command[0] == "append":
            writer.append(ramp_records(n, int(command[1]), RECORD_DTYPE, valid=True))
            n += int(command[1])
            writer.flush()
        elif command[0] == "event":
            writer.add_event(n * 0.002, n, "mark", "therapist's mark", {"n": n})
            writer.flush()
        elif command[0] == "close":
            writer.close("complete", metrics={"score": 1.5})
        elif command[0] == "unflushed":
            # Go on recording without flushing until killed.
            while True:
                writer.append(ramp_records(n, 50, RECORD_DTYPE, valid=True))
                n += 50
                if n % 1000 == 0:
                    print("still writing", flush=True)
        print("ok", n, flush=True)
""")


class WriterProcess:
    """A recorder in its own process, as in the console, driven line by line."""

    def __init__(self, path):
        script = textwrap.dedent(inspect.getsource(ramp_records)) + WRITER
        self.process = subprocess.Popen(
            [sys.executable, "-c", script, str(path)], stdin=subprocess.PIPE,
            stdout=subprocess.PIPE, text=True, cwd=ROOT,
        )

    def send(self, command):
        self.process.stdin.write(command + "\n")
        self.process.stdin.flush()
        return self.process.stdout.readline().strip()

    def stop(self):
        if self.process.poll() is None:
            self.process.kill()
        self.process.wait(timeout=10)
        self.process.stdin.close()
        self.process.stdout.close()


def test_a_file_being_recorded_reads_as_far_as_it_was_flushed(tmp_path):
    path = tmp_path / "live.h5"
    writer = WriterProcess(path)
    try:
        counts = []
        for n in (100, 400, 1000):
            assert writer.send(f"append {n}").startswith("ok")
            trial = read_trial(path)
            counts.append(trial.n_samples)
            assert trial.status == "recording"
            assert not trial.closed
            assert "still being recorded" in trial.notes[0]
            expected = ramp_records(0, trial.n_samples, RECORD_DTYPE, valid=True)
            np.testing.assert_array_equal(trial.channels["position"], expected["position"])
        assert writer.send("event") == "ok 1500"
        assert read_trial(path).events[0]["values"] == {"n": 1500}
        assert writer.send("close") == "ok 1500"
    finally:
        writer.stop()
    assert counts == [100, 500, 1500]
    trial = read_trial(path)
    assert trial.status == "complete"
    assert trial.notes == ()
    assert trial.metrics == {"score": 1.5}
    assert trial.summary["n_samples"] == 1500


def test_a_recorder_killed_mid_trial_leaves_every_flushed_sample(tmp_path):
    path = tmp_path / "killed.h5"
    writer = WriterProcess(path)
    try:
        assert writer.send("append 2000") == "ok 2000"
        assert writer.send("event") == "ok 2000"
        assert writer.send("unflushed") == "still writing"
        writer.process.send_signal(signal.SIGKILL)
    finally:
        writer.stop()
    assert writer.process.returncode == -signal.SIGKILL

    trial = read_trial(path)
    assert trial.status == "recording"
    assert "crash" in trial.notes[0]
    assert trial.n_samples >= 2000
    expected = ramp_records(0, trial.n_samples, RECORD_DTYPE, valid=True)
    for name in RECORD_DTYPE.names:
        np.testing.assert_array_equal(trial.channels[name], expected[name])
    assert [e["kind"] for e in trial.events] == ["mark"]
    assert trial.parameters == THESIS_SUBJECT


@pytest.fixture
def good_file(tmp_path):
    return save(tmp_path / "good.h5", random_records(500, RECORD_DTYPE, seed=7), events=EVENTS)


def read_error(path) -> str:
    with pytest.raises(TrialFileError) as info:
        read_trial(path)
    assert isinstance(info.value, AppError)
    assert str(path) in str(info.value)
    return str(info.value)


def test_a_missing_file(tmp_path):
    assert "does not exist" in read_error(tmp_path / "gone.h5")


def test_an_empty_file(tmp_path):
    path = tmp_path / "empty.h5"
    path.touch()
    assert "is empty (0 bytes)" in read_error(path)


def test_a_folder(tmp_path):
    assert "not a file" in read_error(tmp_path)


def test_random_bytes(tmp_path):
    path = tmp_path / "noise.h5"
    path.write_bytes(np.random.default_rng(8).bytes(20_000))
    assert "not an HDF5 file" in read_error(path)


def test_a_damaged_header(good_file):
    data = bytearray(good_file.read_bytes())
    data[8:64] = bytes(56)  # keep the signature, wreck the superblock after it
    good_file.write_bytes(bytes(data))
    assert "damaged" in read_error(good_file)


@pytest.mark.parametrize("fraction", [0.1, 0.5, 0.97])
def test_a_truncated_file(good_file, fraction):
    data = good_file.read_bytes()
    good_file.write_bytes(data[: int(len(data) * fraction)])
    message = read_error(good_file)
    assert "is truncated" in message
    assert f"of the {len(data)} its header records" in message
    assert "Copy it again" in message


def test_an_hdf5_file_that_is_not_a_trial_file(tmp_path):
    path = tmp_path / "other.h5"
    with h5py.File(path, "w") as f:
        f["x"] = np.arange(3)
    assert "not a rehab-console trial file (it has no 'format' attribute)" in read_error(path)
    with h5py.File(path, "a") as f:
        f.attrs["format"] = "someone-elses-format"
    assert "has format 'someone-elses-format'" in read_error(path)


def test_a_file_from_a_newer_console(good_file):
    with h5py.File(good_file, "a") as f:
        f.attrs["format_version"] = np.int64(FORMAT_VERSION + 1)
    message = read_error(good_file)
    assert f"format version {FORMAT_VERSION + 1}" in message
    assert "Update the console" in message


def test_an_invalid_format_version(good_file):
    with h5py.File(good_file, "a") as f:
        f.attrs["format_version"] = "one"
    assert "invalid format_version" in read_error(good_file)


def test_a_file_without_its_time_series(good_file):
    with h5py.File(good_file, "a") as f:
        del f["timeseries"]
    assert "has no /timeseries" in read_error(good_file)


def crashed(path, records):
    """A file its recorder left without closing (killed, power cut): samples flushed, no
    status but 'recording', no seal; what a crash leaves is then made by hand."""
    from device.recording.trialfile import TrialFileWriter

    writer = TrialFileWriter(path, parameters=PARAMETERS, subject=SUBJECT, robot=ROBOT,
                             backend="simulator", sample_period_s=PERIOD_S,
                             flush_interval_s=None)
    writer.append(records)
    writer.flush()
    writer._abandon()  # the process dies here
    return path


def test_unequal_channel_lengths_are_trimmed_with_a_note(tmp_path):
    # What a crash between two datasets' extends leaves: the later ones shorter.
    path = crashed(tmp_path / "crashed.h5", random_records(500, RECORD_DTYPE, seed=7))
    names = RECORD_DTYPE.names
    with h5py.File(path, "a") as f:
        for name in names[names.index("force") :]:
            f["timeseries"][name].resize(480, axis=0)
    trial = read_trial(path)
    assert {v.shape[0] for v in trial.channels.values()} == {480}
    assert any("unequal lengths (480 to 500 samples)" in note for note in trial.notes)
    expected = random_records(500, RECORD_DTYPE, seed=7)
    np.testing.assert_array_equal(trial.channels["robot_angle"], expected["robot_angle"][:480])
    assert trial.seal == "header verified (not closed)"


def test_rows_reserved_but_never_written_are_dropped_with_a_note(tmp_path):
    path = crashed(tmp_path / "crashed.h5", random_records(500, RECORD_DTYPE, seed=7))
    with h5py.File(path, "a") as f:
        for dataset in f["timeseries"].values():
            dataset.resize(520, axis=0)  # the fill value: tick -1, NaN floats
    trial = read_trial(path)
    assert trial.n_samples == 500
    assert any("the last 20 samples were reserved but never written" in n for n in trial.notes)


def test_parameters_that_no_longer_validate_are_kept_raw_with_a_note(good_file):
    """A file of an older console whose parameters a later one no longer accepts (a range
    since narrowed) is read, its parameters kept raw."""
    stored = PARAMETERS.to_dict() | {"radius_m": 5.0}
    as_format_1(good_file)
    with h5py.File(good_file, "a") as f:
        f.attrs["parameters"] = json.dumps(stored)
    trial = read_trial(good_file)
    assert trial.parameters is None
    assert any("radius_m" in note for note in trial.notes)
    assert json.loads(trial.attrs["parameters"]) == stored
    assert trial.seal == UNSEALED_OLDER
    assert any(note.startswith("unsealed (older format)") for note in trial.notes)


def _written(tmp_path, n=600):
    path = tmp_path / "trial.h5"
    write_trial(path, random_records(n, RECORD_DTYPE, 3), parameters=PARAMETERS,
                subject=SUBJECT, robot=ROBOT, backend="simulator", sample_period_s=PERIOD_S,
                events=EVENTS)
    return path


def _data_offset(path, dataset: str) -> int:
    with h5py.File(path, "r") as f:
        d = f[dataset]
        return d.id.get_chunk_info(0).byte_offset


@pytest.mark.parametrize("dataset", ["timeseries/tick", "timeseries/force", "events"])
def test_a_flipped_bit_is_refused_naming_the_file_and_the_dataset(tmp_path, dataset):
    """52 of 140 bit-flipped files used to load silently (a tick 445 read back as
    1152921504606847421): every dataset now carries a Fletcher-32 checksum."""
    path = _written(tmp_path)
    at = _data_offset(path, dataset) + 40
    raw = bytearray(path.read_bytes())
    raw[at] ^= 0x10
    path.write_bytes(bytes(raw))
    with pytest.raises(TrialFileError) as caught:
        read_trial(path)
    text = str(caught.value)
    assert str(path) in text
    assert "damaged" in text or "checksum" in text
    if dataset != "events":
        assert dataset.split("/")[-1] in text


@pytest.mark.parametrize(("name", "values", "needle"), [
    ("time", lambda t: np.where(np.arange(t.size) == 300, np.nan, t), "time is nan at sample 300"),
    ("time", lambda t: t[::-1].copy(), "time goes from"),
    ("tick", lambda k: np.where(np.arange(k.size) == 445, 1152921504606847421, k),
     "tick goes from 1152921504606847421"),
])
def test_samples_no_trial_can_have_are_refused(tmp_path, name, values, needle):
    """Files written before the checksums, or edited: NaN or backward time, a tick that
    jumps and comes back."""
    path = tmp_path / "trial.h5"
    records = random_records(600, RECORD_DTYPE, 4)
    records[name] = values(records[name])
    write_trial(path, records, parameters=PARAMETERS, subject=SUBJECT, robot=ROBOT,
                backend="simulator", sample_period_s=PERIOD_S)
    with pytest.raises(TrialFileError, match=f"/timeseries/{needle}"):
        read_trial(path)


def test_a_time_stored_as_text_is_refused(tmp_path):
    path = _written(tmp_path)
    with h5py.File(path, "r+") as f:
        del f["timeseries/time"]
        f["timeseries"].create_dataset("time", data=np.array([b"0.0"] * 600))
    with pytest.raises(TrialFileError, match="/timeseries/time holds"):
        read_trial(path)


def test_a_trial_file_reads_while_the_window_writes_beside_it(tmp_path):
    """The window stores a trial's EMG, pose and metrics with HDF5's file locks off; a read
    of the same file at that moment (the report, the Replay tab) used to fail with "file
    locking flag values don't match" (seen in tests/ui/test_main_window_emg.py)."""
    import h5py

    from app.exports.loader import read_info
    from app.trials.headless import save, simulate
    from core.trial import THESIS_SUBJECT
    from device.recording.trialfile import LIBVER

    path = tmp_path / "t.h5"
    save(simulate(THESIS_SUBJECT.replace(repetitions=1)), path)
    with h5py.File(path, "r+", libver=LIBVER, locking=False):  # as device.recording.emgfile
        assert read_trial(path).n_samples > 0
        assert read_info(path).n_samples > 0
