"""The trial-file writer, checked against docs/data-format.md with plain h5py."""

import ctypes
import datetime
import errno
import importlib.metadata
import inspect
import json
import os
import resource
import shutil
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import h5py
import numpy as np
import pytest

import device.recording.trialfile as trialfile
from core.trial import THESIS_SUBJECT
from device.errors import RecordingError
from device.recording.record import CHANNELS, RECORD_DTYPE, Channel, extend_channels
from device.recording.trialfile import (
    EVENT_MESSAGE_BYTES,
    FORMAT_NAME,
    FORMAT_VERSION,
    SubjectInfo,
    TrialFileWriter,
    write_trial,
)
from device.recording.trialfile.recover import clear_open_flags
from device.recording.trialfile.reserve import SpaceShort
from device.recording.trialfile.seal import Seal
from device.recording.trialfile.verify import inventory
from tests.device.smalldisk import DISK_KIND, SmallDisk
from tests.trialfiles import ramp_records

ROOT = Path(__file__).resolve().parents[2]
PERIOD_S = 0.002
PARAMETERS = THESIS_SUBJECT.replace(radius_m=0.08, repetitions=3, clockwise=False)
SUBJECT = SubjectInfo.from_parameters("P-0042", PARAMETERS)
ROBOT = {"name": "thesis robot", "l1_m": 0.1, "l4_m": 0.375}
EMG = Channel("emg", 4, "f4", "V", "none", "surface EMG, four muscles, one sample per tick")


def random_records(n, dtype, rng, start_tick=0):
    """Random values of every field's own dtype, with ticks counting on from start_tick."""
    records = np.zeros(n, dtype=dtype)
    for name in dtype.names:
        field = records[name]
        if field.dtype.kind == "f":
            records[name] = rng.normal(0.0, 10.0, field.shape).astype(field.dtype)
        else:
            info = np.iinfo(field.dtype)
            records[name] = rng.integers(0, min(info.max, 2**31), field.shape, endpoint=True)
    records["tick"] = np.arange(start_tick, start_tick + n)
    records["time"] = records["tick"] * PERIOD_S
    return records


def open_writer(path, **options):
    options = {"parameters": PARAMETERS, "subject": SUBJECT, "robot": ROBOT,
               "backend": "simulator", "sample_period_s": PERIOD_S, **options}
    return TrialFileWriter(path, **options)


def test_round_trip_of_every_channel_attribute_event_and_metric(tmp_path):
    path = tmp_path / "trial.h5"
    rng = np.random.default_rng(1)
    writer = open_writer(path)
    batches, start = [], 0
    for n in (50, 1, 0, 333, 50, 2000):
        batch = random_records(n, RECORD_DTYPE, rng, start)
        writer.append(batch)
        batches.append(batch)
        start += n
    writer.add_event(0.0, 0, "start", "trial started", {"backend": "simulator"})
    writer.add_event(1.25, 625, "fault", "torque limit: 5.1 N·m > 5 N·m",
                     {"torque_Nm": [5.1, 0.2], "code": np.uint16(3)})
    writer.flush()
    writer.close("faulted", {"ring_overruns": 0, "operator_note": "patient tired"},
                 {"rms_error_m": 0.0123, "smoothness": np.float32(-4.5), "n_peaks": 7})
    records = np.concatenate(batches)

    with h5py.File(path, "r") as f:
        series = f["timeseries"]
        assert list(f["channels"]["name"].astype(str)) == [c.name for c in CHANNELS]
        for c, row in zip(CHANNELS, f["channels"][()], strict=True):
            dataset = series[c.name]
            expected_shape = (records.shape[0],) if c.width == 1 else (records.shape[0], c.width)
            assert dataset.shape == expected_shape
            assert dataset.dtype == np.dtype(c.dtype)
            np.testing.assert_array_equal(dataset[()], records[c.name])
            assert dataset.attrs["units"] == c.units
            assert dataset.attrs["frame"] == c.frame
            assert dataset.attrs["description"] == c.description
            assert dataset.maxshape[0] is None
            assert (row["width"], row["units"].decode(), row["frame"].decode()) == (
                c.width, c.units, c.frame)
            assert row["description"].decode() == c.description
            assert np.dtype(row["dtype"].decode()) == np.dtype(c.dtype)

        attrs = f.attrs
        assert attrs["format"] == FORMAT_NAME
        assert attrs["format_version"] == FORMAT_VERSION
        assert attrs["format_version"].dtype.kind == "i"
        assert attrs["software_version"] == importlib.metadata.version("rehab-console")
        created = datetime.datetime.fromisoformat(attrs["created_utc"])
        closed = datetime.datetime.fromisoformat(attrs["closed_utc"])
        assert created.utcoffset() == datetime.timedelta(0)
        assert created <= closed <= datetime.datetime.now(datetime.UTC)
        assert attrs["sample_period_s"] == PERIOD_S
        assert attrs["backend"] == "simulator"
        assert attrs["status"] == "faulted"
        assert json.loads(attrs["parameters"]) == PARAMETERS.to_dict()
        assert json.loads(attrs["subject"]) == SUBJECT.to_dict()
        assert json.loads(attrs["robot"]) == ROBOT

        group = f["parameters"].attrs
        for key, value in PARAMETERS.to_dict().items():
            stored = group[key]
            if isinstance(value, list):
                np.testing.assert_array_equal(stored, value)
            else:
                assert stored == value, key
        assert group["clockwise"].dtype == np.uint8

        events = f["events"][()]
        assert events.dtype["time_s"] == np.float64
        assert events.dtype["tick"] == np.int64
        assert [e["kind"].decode() for e in events] == ["start", "fault"]
        assert events[1]["message"].decode() == "torque limit: 5.1 N·m > 5 N·m"
        assert (events[1]["time_s"], events[1]["tick"]) == (1.25, 625)
        assert json.loads(events[1]["values"]) == {"torque_Nm": [5.1, 0.2], "code": 3}

        metrics = dict(f["metrics"].attrs)
        assert metrics == {"rms_error_m": 0.0123, "smoothness": -4.5, "n_peaks": 7.0}
        assert all(v.dtype == np.float64 for v in metrics.values())

        summary = dict(f["summary"].attrs)
        lateness = records["lateness"].astype(np.float64)
        assert summary["n_samples"] == records.shape[0]
        assert summary["n_events"] == 2
        assert summary["duration_s"] == pytest.approx(records.shape[0] * PERIOD_S)
        assert (summary["first_tick"], summary["last_tick"]) == (0, records.shape[0] - 1)
        assert summary["ticks_missing"] == 0
        assert summary["lateness_max_s"] == pytest.approx(lateness.max())
        assert summary["lateness_p99_s"] == pytest.approx(np.percentile(lateness, 99))
        assert summary["late_fraction"] == pytest.approx(np.mean(lateness >= PERIOD_S))
        assert summary["operator_note"] == "patient tired"
        assert summary["ring_overruns"] == 0


def test_extended_channels_round_trip(tmp_path):
    channels, dtype = extend_channels((EMG,))
    rng = np.random.default_rng(2)
    records = random_records(700, dtype, rng)
    path = write_trial(tmp_path / "emg.h5", records, parameters=PARAMETERS, subject=SUBJECT,
                       robot=ROBOT, backend="simulator", sample_period_s=PERIOD_S,
                       channels=channels)
    with h5py.File(path, "r") as f:
        emg = f["timeseries/emg"]
        assert emg.shape == (700, 4)
        assert emg.dtype == np.float32
        assert emg.attrs["units"] == "V"
        np.testing.assert_array_equal(emg[()], records["emg"])
        np.testing.assert_array_equal(f["timeseries/force_sensor"][()], records["force_sensor"])
        assert f["channels"]["name"][-1] == b"emg"


def test_records_are_matched_by_field_name_not_position(tmp_path):
    reordered = np.dtype([(n, RECORD_DTYPE[n]) for n in reversed(RECORD_DTYPE.names)])
    records = random_records(10, reordered, np.random.default_rng(3))
    writer = open_writer(tmp_path / "t.h5")
    writer.append(records)
    writer.close("complete")
    with h5py.File(tmp_path / "t.h5", "r") as f:
        np.testing.assert_array_equal(f["timeseries/position"][()], records["position"])


def test_records_that_do_not_match_the_channels_are_refused(tmp_path):
    writer = open_writer(tmp_path / "t.h5")
    _, emg_dtype = extend_channels((EMG,))
    with pytest.raises(RecordingError, match="unknown: emg"):
        writer.append(np.zeros(3, dtype=emg_dtype))
    wrong = np.dtype([(n, "f4" if n == "force" else RECORD_DTYPE[n])
                      for n in RECORD_DTYPE.names])
    with pytest.raises(RecordingError, match="channel force is"):
        writer.append(np.zeros(3, dtype=wrong))
    with pytest.raises(RecordingError, match="1-D structured"):
        writer.append(np.zeros((3, 2)))
    writer.append(np.zeros(3, dtype=RECORD_DTYPE))
    writer.close("complete")
    with h5py.File(tmp_path / "t.h5", "r") as f:
        assert f["timeseries/force"].shape == (3, 2)


def test_bad_close_arguments_are_refused_and_the_file_can_still_be_closed(tmp_path):
    writer = open_writer(tmp_path / "t.h5")
    writer.append(np.zeros(5, dtype=RECORD_DTYPE))
    with pytest.raises(RecordingError, match="give one of complete"):
        writer.close("done")
    with pytest.raises(RecordingError, match="metric rms"):
        writer.close("complete", metrics={"rms": "small"})
    with pytest.raises(RecordingError, match="summary notes"):
        writer.close("complete", summary={"notes": [1, 2]})
    assert not writer.closed
    writer.close("stopped_early")
    with pytest.raises(RecordingError, match="closed"):
        writer.append(np.zeros(1, dtype=RECORD_DTYPE))
    with pytest.raises(RecordingError, match="already closed"):
        writer.close("complete")
    with h5py.File(tmp_path / "t.h5", "r") as f:
        assert f.attrs["status"] == "stopped_early"


def test_long_event_text_is_cut_on_a_character_boundary(tmp_path):
    writer = open_writer(tmp_path / "t.h5")
    writer.add_event(0.5, 250, "mark", "é" * EVENT_MESSAGE_BYTES, {"x": "y" * 5000})
    with pytest.raises(RecordingError, match="event kind"):
        writer.add_event(0.5, 250, "", "no kind")
    writer.close("complete")
    with h5py.File(tmp_path / "t.h5", "r") as f:
        row = f["events"][0]
    message = row["message"].decode("utf-8")  # must still be valid UTF-8
    assert message.endswith("…")
    assert set(message[:-1]) == {"é"}
    values = json.loads(row["values"])
    assert values["keys"] == ["x"]
    assert "exceed" in values["values_dropped"]


def test_subject_codes_refuse_names():
    with pytest.raises(RecordingError, match="names never go into trial files"):
        SubjectInfo.from_parameters("Jane Doe", PARAMETERS)
    with pytest.raises(RecordingError, match="body_mass_kg"):
        SubjectInfo("P-1", -3.0, 0.3, 0.3, "right")
    with pytest.raises(RecordingError, match="side"):
        SubjectInfo("P-1", 70.0, 0.3, 0.3, "both")


def test_write_trial_makes_a_closed_file_without_the_swmr_flag(tmp_path):
    records = random_records(100, RECORD_DTYPE, np.random.default_rng(4))
    events = [{"time_s": 0.0, "tick": 0, "kind": "start", "message": ""},
              {"time_s": 0.2, "tick": 99, "kind": "stop", "message": "end", "values": {"a": 1}}]
    path = write_trial(tmp_path / "t.h5", records, parameters=PARAMETERS, subject=SUBJECT,
                       robot=ROBOT, backend="headless", sample_period_s=PERIOD_S,
                       events=events, metrics={"x_m": 1.0}, summary={"n_samples": 5})
    # A plain, non-SWMR open succeeds only when no writer flag is left set.
    with h5py.File(path, "r") as f:
        assert f.attrs["status"] == "complete"
        assert f["events"].shape == (2,)
        assert f["summary"].attrs["n_samples"] == 5  # the caller's summary wins
        assert f["metrics"].attrs["x_m"] == 1.0


def test_a_copy_taken_mid_trial_holds_every_flushed_sample(tmp_path):
    path = tmp_path / "live.h5"
    writer = open_writer(path, flush_interval_s=None)
    writer.append(ramp_records(0, 1500, RECORD_DTYPE))
    writer.add_event(0.1, 50, "mark", "flushed")
    writer.flush()
    writer.append(ramp_records(1500, 500, RECORD_DTYPE))  # not flushed: may or may not be there
    copy = tmp_path / "copy.h5"
    shutil.copyfile(path, copy)
    writer.close("complete")

    with pytest.raises(OSError, match="already open for write"):
        h5py.File(copy, "r")  # the copy carries the live file's SWMR-writing flag
    with h5py.File(copy, "r", swmr=True) as f:
        assert f.attrs["status"] == "recording"
        ticks = f["timeseries/tick"][()]
        assert ticks.shape[0] >= 1500
        expected = ramp_records(0, ticks.shape[0], RECORD_DTYPE)
        for name in RECORD_DTYPE.names:
            np.testing.assert_array_equal(f["timeseries"][name][()], expected[name])
        assert f["events"][0]["message"] == b"flushed"


def test_append_flushes_by_itself_when_the_recorder_does_not(tmp_path):
    path = tmp_path / "live.h5"
    writer = open_writer(path, flush_interval_s=0.0)
    writer.append(ramp_records(0, 300, RECORD_DTYPE))
    copy = tmp_path / "copy.h5"
    shutil.copyfile(path, copy)
    writer.close("complete")
    with h5py.File(copy, "r", swmr=True) as f:
        assert f["timeseries/tick"].shape == (300,)


READER = textwrap.dedent("""
    import sys, h5py
    f = h5py.File(sys.argv[1], "r", swmr=True)
    ticks = f["timeseries/tick"]
    for line in sys.stdin:
        ticks.refresh()
        f["timeseries/position"].refresh()
        last = f["timeseries/position"][-1, 1] if ticks.shape[0] else -1.0
        print(ticks.shape[0], int(ticks[-1]) if ticks.shape[0] else -1, last, flush=True)
""")


def test_a_reader_sees_the_data_grow_while_the_writer_appends(tmp_path):
    path = tmp_path / "live.h5"
    writer = open_writer(path, flush_interval_s=None)
    reader = subprocess.Popen([sys.executable, "-c", READER, str(path)], stdin=subprocess.PIPE,
                              stdout=subprocess.PIPE, text=True, cwd=ROOT)
    try:
        seen = []
        for step in range(4):
            writer.append(ramp_records(step * 250, 250, RECORD_DTYPE))
            writer.flush()
            reader.stdin.write("next\n")
            reader.stdin.flush()
            n, last_tick, last_y = reader.stdout.readline().split()
            seen.append((int(n), int(last_tick), float(last_y)))
        # The reader still holds the file open: closing must still write the status.
        writer.close("complete")
    finally:
        reader.stdin.close()
        reader.wait(timeout=10)
        reader.stdout.close()
    position_k = RECORD_DTYPE.names.index("position")
    assert seen == [(n, n - 1, (n - 1) * 1e-3 + position_k) for n in (250, 500, 750, 1000)]
    assert reader.returncode == 0
    with h5py.File(path, "r") as f:
        assert f.attrs["status"] == "complete"


def test_an_existing_file_is_never_overwritten(tmp_path):
    path = tmp_path / "t.h5"
    path.write_bytes(b"precious")
    with pytest.raises(RecordingError, match="never overwritten") as info:
        open_writer(path)
    assert str(path) in str(info.value)
    assert path.read_bytes() == b"precious"


def test_a_missing_folder_is_a_recording_error(tmp_path):
    path = tmp_path / "no" / "such" / "t.h5"
    with pytest.raises(RecordingError, match="does not exist") as info:
        open_writer(path)
    assert str(path) in str(info.value)


def _without_dac_override():
    # Root ignores file permissions; dropping this capability makes it obey them.
    libc = ctypes.CDLL(None, use_errno=True)
    pr_capbset_drop, cap_dac_override = 24, 1
    if libc.prctl(pr_capbset_drop, cap_dac_override, 0, 0, 0) != 0:
        raise OSError(ctypes.get_errno(), "prctl(PR_CAPBSET_DROP)")


WRITER_IN_FOLDER = textwrap.dedent("""
    import sys
    from core.trial import THESIS_SUBJECT
    from device.errors import RecordingError
    from device.recording.trialfile import SubjectInfo, TrialFileWriter
    try:
        TrialFileWriter(sys.argv[1], parameters=THESIS_SUBJECT,
                        subject=SubjectInfo.from_parameters("P-1", THESIS_SUBJECT),
                        robot={}, backend="simulator", sample_period_s=0.002)
    except RecordingError as exc:
        print(exc)
""")


def test_an_unwritable_folder_is_a_recording_error(tmp_path):
    folder = tmp_path / "read-only"
    folder.mkdir()
    folder.chmod(0o555)
    path = folder / "t.h5"
    try:
        result = subprocess.run(
            [sys.executable, "-c", WRITER_IN_FOLDER, str(path)], capture_output=True, text=True,
            cwd=ROOT, timeout=30, preexec_fn=_without_dac_override if os.geteuid() == 0 else None,
        )
    except subprocess.SubprocessError as exc:
        pytest.skip(f"cannot drop root's permission override here: {exc}")
    finally:
        folder.chmod(0o755)
    assert result.returncode == 0, result.stderr
    assert "permission denied" in result.stdout
    assert str(path) in result.stdout
    assert not path.exists()


def test_a_nearly_full_disk_stops_the_recording_while_the_file_can_be_closed(
    tmp_path, monkeypatch
):
    with pytest.raises(RecordingError, match="MiB free") as info:
        open_writer(tmp_path / "refused.h5", min_free_bytes=2**62)
    assert "refused.h5" in str(info.value)
    assert not (tmp_path / "refused.h5").exists()

    path = tmp_path / "t.h5"
    writer = open_writer(path)
    assert writer.space_held
    writer.append(ramp_records(0, 100, RECORD_DTYPE))
    monkeypatch.setattr(trialfile.writer, "_free_bytes", lambda folder: 10 * 2**20)
    with pytest.raises(SpaceShort, match=r"sample 100: only 10 MiB free"):
        writer.flush()
    # said once; the trial's last samples go into the space the file holds
    writer.append(ramp_records(100, 10, RECORD_DTYPE))
    writer.flush()
    writer.close("recording_lost")
    with h5py.File(path, "r") as f:
        assert f.attrs["status"] == "recording_lost"
        assert f["timeseries/tick"].shape == (110,)


def test_where_no_space_can_be_held_a_nearly_full_disk_ends_the_writing(tmp_path, monkeypatch):
    def unsupported(*_args):
        raise OSError(errno.EOPNOTSUPP, "Operation not supported")

    monkeypatch.setattr(trialfile.reserve, "fallocate", unsupported)
    path = tmp_path / "t.h5"
    writer = open_writer(path)
    assert not writer.space_held
    writer.append(ramp_records(0, 100, RECORD_DTYPE))
    monkeypatch.setattr(trialfile.writer, "_free_bytes", lambda folder: 10 * 2**20)
    with pytest.raises(SpaceShort, match=r"sample 100: only 10 MiB free"):
        writer.flush()
    with pytest.raises(RecordingError, match="recording_lost"):
        writer.append(ramp_records(100, 10, RECORD_DTYPE))
    writer.close("recording_lost")
    with h5py.File(path, "r") as f:
        assert f.attrs["status"] == "recording_lost"
        assert f["timeseries/tick"].shape == (100,)


@pytest.fixture
def small_disk(tmp_path):
    with SmallDisk(tmp_path, 16) as disk:
        yield disk


@pytest.mark.parametrize("kind", [DISK_KIND])
def test_a_disk_filled_by_another_program_keeps_every_sample_readable(small_disk, kind):
    """Issue 28 #2: a disk filled to 100 % by another program during a live trial left the
    file flagged open for writing and unreadable ("file is not already open for SWMR
    writing"), every sample lost. The writer now holds space beyond the file's end, so
    the trial's last samples, its events and the close all find room."""
    path = small_disk.root / "t.h5"
    writer = open_writer(path, min_free_bytes=0)
    small_disk.fill()  # from the first sample on: the space held since the header
    writer.append(ramp_records(0, 1500, RECORD_DTYPE))
    writer.append(ramp_records(1500, 600, RECORD_DTYPE))  # 1.2 s more of the trial
    with pytest.raises(SpaceShort, match="full"):
        writer.flush()
    writer.add_event(4.2, 2100, "fault", "recording lost", {"cause": "disk full"})
    writer.append(ramp_records(2100, 50, RECORD_DTYPE))  # until the loop's stop
    writer.close("recording_lost", {"samples_saved": 2150})
    assert not writer.close_problem
    for swmr in (False, True):
        with h5py.File(path, "r", swmr=swmr) as f:
            assert f.attrs["status"] == "recording_lost"
            np.testing.assert_array_equal(f["timeseries/tick"][()], np.arange(2150))
            assert f["events"][-1]["kind"] == b"fault"
            assert f["summary"].attrs["samples_saved"] == 2150
    small_disk.free()


FILLING_WRITER = textwrap.dedent("""
    import os, sys
    from device.errors import RecordingError
    from device.recording.record import RECORD_DTYPE
    from device.recording.trialfile import SubjectInfo, TrialFileWriter
    from core.trial import THESIS_SUBJECT
    writer = TrialFileWriter(sys.argv[1], parameters=THESIS_SUBJECT,
                             subject=SubjectInfo.from_parameters("P-1", THESIS_SUBJECT),
                             robot={}, backend="simulator", sample_period_s=0.002,
                             flush_interval_s=None, min_free_bytes=0)
    start = 0
    try:
        while True:
            writer.append(ramp_records(start, 250, RECORD_DTYPE))
            start += 250
            writer.flush()
            print("flushed", start, flush=True)
    except RecordingError as exc:
        print("error", exc, flush=True)
    # HDF5 cannot close a file whose writes failed; leave without trying.
    os._exit(0)
""")


def _limit_file_size():
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    resource.setrlimit(resource.RLIMIT_FSIZE, (1_000_000, resource.RLIM_INFINITY))


def test_a_failed_write_is_a_recording_error_and_flushed_samples_survive(tmp_path):
    # A file-size limit fails writes the way a full disk does, without filling one.
    path = tmp_path / "t.h5"
    script = textwrap.dedent(inspect.getsource(ramp_records)) + FILLING_WRITER
    result = subprocess.run([sys.executable, "-c", script, str(path)], capture_output=True,
                             text=True, cwd=ROOT, timeout=60, preexec_fn=_limit_file_size)
    lines = result.stdout.splitlines()
    assert lines[-1].startswith("error could not"), result.stdout + result.stderr
    assert str(path) in lines[-1]
    assert "full" in lines[-1]
    flushed = int(lines[-2].split()[1])
    assert flushed >= 1000
    with h5py.File(path, "r", swmr=True) as f:
        ticks = f["timeseries/tick"][()]
        assert ticks.shape[0] >= flushed
        np.testing.assert_array_equal(ticks[:flushed], np.arange(flushed))


DOC = ROOT / "docs" / "data-format.md"


def test_the_format_document_lists_every_channel_and_status():
    text = DOC.read_text(encoding="utf-8")
    for c in CHANNELS:
        shape = "(N,)" if c.width == 1 else f"(N, {c.width})"
        dtype = np.dtype(c.dtype).str.replace("|", "\\|")
        assert f"| `{c.name}` | {shape} | {dtype} | {c.units} |" in text, c.name
    for status in ("recording", *trialfile.STATUSES):
        assert f"| `{status}` |" in text


def test_the_python_examples_in_the_format_document_run(tmp_path, monkeypatch, capsys):
    blocks = [b.split("```")[0] for b in DOC.read_text(encoding="utf-8").split("```python\n")[1:]]
    assert len(blocks) == 3
    swmr_block = next(b for b in blocks if "swmr=True" in b)
    emg_block = next(b for b in blocks if "emg/samples" in b)
    plain_block = next(b for b in blocks if b not in (swmr_block, emg_block))
    records = ramp_records(0, 50, RECORD_DTYPE)
    write_trial(tmp_path / "trial.h5", records, parameters=PARAMETERS, subject=SUBJECT,
                robot=ROBOT, backend="simulator", sample_period_s=PERIOD_S,
                events=[{"time_s": 0.0, "tick": 0, "kind": "start", "message": "go"}],
                metrics={"rms_error_m": 0.01})
    monkeypatch.chdir(tmp_path)
    swmr, plain = {}, {}
    exec(swmr_block, swmr)
    exec(plain_block, plain)
    assert capsys.readouterr().out.startswith("50 samples so far\n")
    np.testing.assert_array_equal(plain["xy"], records["position"])
    assert plain["channels"] == [c.name for c in CHANNELS]
    assert plain["parameters"] == PARAMETERS.to_dict()
    assert plain["metrics"] == {"rms_error_m": 0.01}
    # the EMG example, on the same file with EMG stored (device.recording.emgfile)
    from device.recording.emgfile import write_emg

    emg = np.arange(20.0).reshape(10, 2) * 1e-4
    write_emg(tmp_path / "trial.h5", names=["EMG1", "EMG2"], muscles=["biceps", "triceps"],
              rate_hz=1000.0, time_s=np.arange(10) / 1000.0, samples=emg, source="test",
              clock="trial clock", offset_s=0.0)
    read: dict = {}
    exec(emg_block, read)
    np.testing.assert_array_equal(read["emg"], emg)
    assert read["muscles"] == ["biceps", "triceps"]
    assert read["rate_hz"] == 1000.0


def test_the_console_adds_to_a_closed_trial_s_assistance_and_overwrites_nothing(tmp_path):
    """add_assistance: a live trial's estimates of the patient's force, stored after the
    recorder closed the file; what the group holds is never replaced."""
    from device.errors import RecordingError
    from device.recording.trialfile import add_assistance

    records = random_records(50, RECORD_DTYPE, np.random.default_rng(5))
    path = write_trial(tmp_path / "t.h5", records, parameters=PARAMETERS, subject=SUBJECT,
                       robot=ROBOT, backend="headless", sample_period_s=PERIOD_S,
                       assistance={"mode": "thesis", "level": 1.0})
    add_assistance(path, {"estimate_model": "s1", "estimate_force": np.ones((3, 2))})
    with h5py.File(path, "r") as f:
        a = f["assistance"]
        assert a.attrs["mode"] == "thesis"
        assert a.attrs["estimate_model"] == "s1"
        assert a["estimate_force"].shape == (3, 2)
        assert a["estimate_force"].fletcher32
    with pytest.raises(RecordingError, match="already has estimate_force, mode"):
        add_assistance(path, {"mode": "as-needed", "estimate_force": np.zeros((1, 2))})
    with h5py.File(path, "r") as f:
        assert f["assistance"].attrs["mode"] == "thesis"
        assert f["assistance/estimate_force"][0, 0] == 1.0


def closed_trial(tmp_path) -> Path:
    records = random_records(50, RECORD_DTYPE, np.random.default_rng(5))
    return write_trial(tmp_path / "t.h5", records, parameters=PARAMETERS, subject=SUBJECT,
                       robot=ROBOT, backend="headless", sample_period_s=PERIOD_S)


def test_an_update_waits_for_a_reader_in_this_process_instead_of_losing_what_it_stores(
        tmp_path, monkeypatch):
    """In one process HDF5 will not open a file for writing while it is open for reading
    (the window's report or replay, a loader). A live trial's EMG estimates were lost that
    way ("file is already open for read-only", a fresh-clone check on 2026-12-02): the
    store now waits for the reader, as every update of a closed trial file does."""
    import threading

    from device.recording.trialfile import add_assistance, write_metrics

    path = closed_trial(tmp_path)
    # the store waits as long as this test holds the reader, however late this thread runs
    # on a loaded machine (the bound, UPDATE_WAIT_S, is the next test's)
    monkeypatch.setattr(trialfile.update, "UPDATE_WAIT_S", 600.0)
    reader = h5py.File(path, "r", locking=False)
    original, tries, tried_again = h5py.File, [], threading.Event()

    def counted(*args, **kwargs):
        if args[1:2] == ("r+",):
            tries.append(args[0])
            if len(tries) == 2:
                tried_again.set()
        return original(*args, **kwargs)

    monkeypatch.setattr(h5py, "File", counted)
    errors = []

    def store():
        try:
            add_assistance(path, {"estimate_model": "s1", "estimate_force": np.ones((3, 2))})
            write_metrics(path, {"rmse_x_m": 0.001})
        except Exception as exc:  # kept for the assertion below
            errors.append(exc)

    writer = threading.Thread(target=store)
    writer.start()
    assert tried_again.wait(30)  # refused while the reader holds it, and tried again
    reader.close()
    writer.join(30)
    assert errors == []
    with original(path, "r") as f:
        assert f["assistance"].attrs["estimate_model"] == "s1"
        assert f["metrics"].attrs["rmse_x_m"] == 0.001


def test_a_reader_that_never_lets_go_is_named_not_the_disk(tmp_path, monkeypatch):
    """The wait is bounded (UPDATE_WAIT_S); then the line says who holds the file."""
    from device.recording.trialfile import add_assistance

    path = closed_trial(tmp_path)
    clock = [0.0]

    def sleep(seconds):
        clock[0] += seconds

    with h5py.File(path, "r", locking=False):
        with (pytest.raises(OSError, match="already open for read-only"),
              trialfile.open_for_update(path, "/metrics", wait_s=1.0, sleep=sleep,
                                        clock=lambda: clock[0])):
            pass
        assert clock[0] == pytest.approx(1.0, abs=trialfile.UPDATE_RETRY_S)
        monkeypatch.setattr(trialfile.update, "UPDATE_WAIT_S", 0.0)
        with pytest.raises(RecordingError) as caught:
            add_assistance(path, {"estimate_model": "s1"})
    text = str(caught.value)
    assert "open for reading in this console" in text
    assert "close that, then store again" in text
    assert "disk" not in text
    assert "\n" not in text
    # another error is not waited on
    waited = clock[0]
    with (pytest.raises(OSError, match=r"No such file|unable to open"),
          trialfile.open_for_update(tmp_path / "none.h5", "/metrics", sleep=sleep,
                                    clock=lambda: clock[0])):
        pass
    assert clock[0] == waited


def test_the_timing_summary_reads_its_channels_a_block_at_a_time(tmp_path, monkeypatch):
    """Issue 13 #21: close() computed the lateness and compute-time summary from the
    whole channels, and read the whole tick channel for its first and last tick (at
    6 million ticks, 150 MB at the end of a headless trial). Now no read of those
    channels is longer than SUMMARY_BLOCK, and the figures are numpy's on the whole."""
    monkeypatch.setattr(trialfile.summary, "SUMMARY_BLOCK", 1000)
    rng = np.random.default_rng(5)
    records = random_records(5500, RECORD_DTYPE, rng)
    records["lateness"] = np.abs(rng.normal(0.0, 0.002, 5500)).astype(np.float32)
    records["lateness"][17] = np.nan
    reads = []
    getitem = h5py.Dataset.__getitem__

    def watched(self, selection):
        values = getitem(self, selection)
        if self.name.rsplit("/", 1)[-1] in ("tick", "lateness", "compute_time"):
            reads.append(np.size(values))
        return values

    writer = open_writer(tmp_path / "t.h5", live=False)
    writer.append(records)
    monkeypatch.setattr(h5py.Dataset, "__getitem__", watched)
    writer.close("complete")
    monkeypatch.undo()
    assert reads
    assert max(reads) <= 1000
    with h5py.File(tmp_path / "t.h5", "r") as f:
        summary = dict(f["summary"].attrs)
    for name in ("lateness", "compute_time"):
        values = records[name].astype(np.float64)
        values = values[np.isfinite(values)]
        assert summary[f"{name}_p50_s"] == np.percentile(values, 50)
        assert summary[f"{name}_p99_s"] == np.percentile(values, 99)
        assert summary[f"{name}_max_s"] == values.max()
        assert summary[f"{name}_mean_s"] == pytest.approx(values.mean(), rel=1e-12)
    late = records["lateness"].astype(np.float64)
    late = late[np.isfinite(late)]
    assert summary["late_fraction"] == np.mean(late >= PERIOD_S)
    assert (summary["first_tick"], summary["last_tick"]) == (0, 5499)


@pytest.mark.parametrize("kind", [DISK_KIND])
def test_an_addition_on_a_full_disk_leaves_the_file_as_it_was(small_disk, kind):
    """Issue 28 #2: the metrics, EMG or pose added after a trial opened the file for writing
    on a full disk; the write failed and left it flagged open for writing, unreadable. Now
    the space for the addition is held first: on a full disk nothing is added, in one
    line, and the file reads as before."""
    path = small_disk.root / "t.h5"
    writer = open_writer(path, min_free_bytes=0)
    writer.append(ramp_records(0, 2000, RECORD_DTYPE))
    writer.close("complete")
    small_disk.fill()
    with pytest.raises(SpaceShort, match=r"nothing was added to t\.h5") as caught:
        trialfile.write_metrics(path, {f"metric_{i}": float(i) for i in range(200)})
    assert "\n" not in str(caught.value)
    for swmr in (False, True):
        with h5py.File(path, "r", swmr=swmr) as f:
            assert f.attrs["status"] == "complete"
            assert f["timeseries/tick"].shape == (2000,)
            assert not f["metrics"].attrs
    small_disk.free()
    trialfile.write_metrics(path, {"rmse_x_m": 0.01})  # with room again, it is added
    with h5py.File(path, "r") as f:
        assert f["metrics"].attrs["rmse_x_m"] == 0.01


def test_a_trial_file_appears_under_its_name_only_once_it_reads(tmp_path, monkeypatch):
    """A reader polling for the trial's file (the live replay, a test of a killed recorder)
    met it while its header was written, flagged open for plain writing: 'file is not
    already open for SWMR writing', read as damaged. The file is now made under a hidden
    name and linked to its own once an SWMR reader can open it."""
    path = tmp_path / "t.h5"
    seen = []
    publish = TrialFileWriter._publish

    def watched(self):
        seen.append(path.exists())
        with h5py.File(self._making, "r", swmr=True) as f:  # readable before it is named
            seen.append(f.attrs["status"])
        publish(self)

    monkeypatch.setattr(TrialFileWriter, "_publish", watched)
    writer = open_writer(path)
    assert seen == [False, "recording"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["t.h5"]
    writer.close("complete")
    with pytest.raises(RecordingError, match="a file of that name exists"):
        open_writer(path)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["t.h5"]


KILLED_MID_BATCH = textwrap.dedent("""
    import os, sys
    import numpy as np
    from core.trial import THESIS_SUBJECT
    from device.recording.record import RECORD_DTYPE
    from device.recording.trialfile import SubjectInfo, TrialFileWriter
    writer = TrialFileWriter(sys.argv[1], parameters=THESIS_SUBJECT,
                             subject=SubjectInfo.from_parameters("P-1", THESIS_SUBJECT),
                             robot={}, backend="simulator", sample_period_s=0.002)
    writer.append(ramp_records(0, 1000, RECORD_DTYPE))
    writer.flush()
    # the next batch: killed after its extent and data reached five of the datasets
    done = []
    for index, (name, dataset_id, tail) in enumerate(writer._datasets):
        class Killing:
            def __init__(self, inner): self.inner = inner
            def __getattr__(self, attr): return getattr(self.inner, attr)
            def write(self, *args):
                self.inner.write(*args)
                done.append(1)
                if len(done) == 5:
                    writer._file.flush()
                    os.kill(os.getpid(), 9)
        writer._datasets[index] = (name, Killing(dataset_id), tail)
    writer.append(ramp_records(1000, 500, RECORD_DTYPE))
""")


@pytest.fixture(scope="module")
def killed_mid_batch(tmp_path_factory):
    """A trial file whose writer was killed inside a batch (copy it before use)."""
    path = tmp_path_factory.mktemp("killed") / "t.h5"
    script = "\n".join([textwrap.dedent(inspect.getsource(ramp_records)), KILLED_MID_BATCH])
    ran = subprocess.run([sys.executable, "-c", script, str(path)], cwd=ROOT,
                         capture_output=True, text=True, timeout=120)
    assert ran.returncode == -signal.SIGKILL, ran.stderr
    return path


def all_parts_match_the_seal(path) -> bool:
    """Every group and dataset of a closed file digested anew and compared with its seal."""
    with h5py.File(path, "r") as f:
        found = inventory(f)
        sealed = Seal.read(f)
        assert sealed is not None, "no seal"
        sealed.check_structure(found)
        for part in sorted(found.paths):
            sealed.check(part, found)
    return True


def test_a_dead_writer_s_file_is_taken_over_where_its_samples_are_whole(tmp_path,
                                                                       killed_mid_batch):
    """Issue 28 #6: the console finishes a killed recorder's file from the ring. The file
    is taken over from the dead writer (its flags cleared), every channel cut to the
    samples all of them hold (a writer killed inside a batch leaves the first channels
    longer), and what comes next follows on from there; the file is sealed at its close
    as one the recorder closed itself (the samples the dead writer left digested when it
    is taken over: the taken-over writer had no digests and its first append raised)."""
    path = tmp_path / "t.h5"
    shutil.copyfile(killed_mid_batch, path)
    with h5py.File(path, "r", swmr=True) as f:
        lengths = {f[f"timeseries/{name}"].shape[0] for name in RECORD_DTYPE.names}
    assert lengths == {1000, 1500}  # the batch half written
    writer = TrialFileWriter.resume(path)
    assert writer.n_samples == 1000
    writer.append(ramp_records(1000, 600, RECORD_DTYPE))
    writer.add_event(3.2, 1599, "recording", "taken over", {})
    writer.close("recording_lost")
    with h5py.File(path, "r") as f:
        assert f.attrs["status"] == "recording_lost"
        for name in RECORD_DTYPE.names:
            assert f[f"timeseries/{name}"].shape[0] == 1600, name
        np.testing.assert_array_equal(f["timeseries/tick"][()], np.arange(1600))
        assert f["summary"].attrs["n_samples"] == 1600
        assert [e["kind"] for e in f["events"][()]] == [b"recording"]
    assert all_parts_match_the_seal(path)


def test_a_dead_writer_s_file_with_a_damaged_header_is_not_taken_over(tmp_path,
                                                                     killed_mid_batch):
    """A file whose header no longer matches its digest (its subject changed while the
    console was down) is not taken over and sealed as the console's: refused in one line,
    its samples left as they are."""
    path = tmp_path / "t.h5"
    shutil.copyfile(killed_mid_batch, path)
    clear_open_flags(path)
    with h5py.File(path, "r+") as f:
        f.attrs["subject"] = f.attrs["subject"].replace("P-1", "P-2")
        lengths = {f[f"timeseries/{name}"].shape[0] for name in RECORD_DTYPE.names}
    with pytest.raises(RecordingError, match="is damaged: its header") as refused:
        TrialFileWriter.resume(path)
    assert "\n" not in str(refused.value)
    assert "not taken over" in str(refused.value)
    with h5py.File(path, "r") as f:
        assert "seal" not in f.attrs
        assert {f[f"timeseries/{name}"].shape[0] for name in RECORD_DTYPE.names} == lengths


def test_a_trial_file_is_its_users_only_from_its_first_moment(tmp_path, monkeypatch):
    """A patient's data, whatever the umask: HDF5 made the file with the umask's mode and
    a chmod followed, an instant in which another user could open it and go on reading
    all that was written later through that descriptor (issue 28 #1, private modes by the
    library)."""
    from device.recording.trialfile import making

    modes = []
    opened = making.h5py.File

    def watched(name, *args, **kwargs):
        f = opened(name, *args, **kwargs)
        modes.append(os.stat(name).st_mode & 0o777)  # the moment HDF5 has made it
        return f

    monkeypatch.setattr(making.h5py, "File", watched)
    old = os.umask(0o022)
    try:
        writer = open_writer(tmp_path / "t.h5")
    finally:
        os.umask(old)
    writer.close("complete")
    assert modes[:1] == [0o600]
    assert os.stat(tmp_path / "t.h5").st_mode & 0o777 == 0o600
    assert sorted(p.name for p in tmp_path.iterdir()) == ["t.h5"]
