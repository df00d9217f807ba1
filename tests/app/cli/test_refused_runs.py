"""A refused or failed registered run withdraws everything it began (issue 28 #4): a `rehab
run --code P --shape reach` out of the arm's reach once left a trial 'recording' with no
file, and every later `rehab export --patient P` exited 1. The registry row and the file
begin and end together (app.trials.registered), whatever stops the run."""

from __future__ import annotations

import pytest

from app.errors import AppError
from app.records.datadir import DataDir
from app.records.registry import Registry
from core.errors import ParameterError
from tests.app.cli.running import run

pytestmark = pytest.mark.usefixtures("data")  # the folders of tests/app/cli/conftest.py

SHORT = ["--repetitions", "1", "--duration", "3"]


@pytest.fixture
def patient(capsys) -> str:
    code, out, err = run(["patients", "add", "--first-name", "Ada", "--last-name", "Test",
                          "--body-mass", "70", "--upper-arm", "0.30", "--forearm", "0.28",
                          "--side", "right", "--shoulder", "-0.12", "0.73"], capsys)
    assert code == 0, err
    return out.strip()


def trials_and_files(data, code):
    registry = Registry(DataDir(data))
    files = sorted((data / "trials" / code).glob("*")) if (data / "trials" / code).is_dir() \
        else []
    return [(t.status, registry.trial_path(t).exists()) for t in
            registry.trials_for_patient(code)], files


def exports_cleanly(data, code, capsys, tmp_path) -> None:
    out_folder = tmp_path / f"export-{len(list(tmp_path.iterdir()))}"
    code_, out, err = run(["export", "--patient", code, "--output", str(out_folder)], capsys)
    assert code_ == 0, out + err


def test_a_run_out_of_reach_leaves_no_trial(data, patient, capsys, tmp_path):
    code, _, err = run(["run", "--code", patient, "--shape", "reach", "--duration", "2",
                        "--repetitions", "1"], capsys)
    assert code == 2
    assert err.count("\n") == 1
    assert "this arm reaches" in err
    assert "the trial was not registered" in err
    assert trials_and_files(data, patient) == ([], [])
    exports_cleanly(data, patient, capsys, tmp_path)
    # and the next trial takes the number the refused one would have had
    code, out, err = run(["run", "--code", patient, *SHORT], capsys)
    assert code == 0, err
    assert "session 1, trial 1" in out


@pytest.mark.parametrize(("stop", "after_blocks", "expected"), [
    # refused before any sample reached the file: the file goes with the row
    (ParameterError("estimate", 1, "a refusal"), 0, ([], [])),
    (KeyboardInterrupt(), 0, ([], [])),
    # failed part-way: what reached the file is kept, the trial finished as recording lost
    (ParameterError("estimate", 2, "a stop"), 1, ([("recording_lost", True)], 1)),
    (ValueError("a library's own error"), 1, ([("recording_lost", True)], 1)),
    (AppError("a refusal of the application"), 1, ([("recording_lost", True)], 1)),
])
def test_a_run_stopped_at_any_point_leaves_no_ghost(data, patient, capsys, tmp_path,
                                                    monkeypatch, stop, after_blocks,
                                                    expected):
    """Whatever stops the simulation (a refusal of core, of the application, a library's
    error, Ctrl-C), before or after samples reached the file."""
    from app.trials import headless

    simulate = headless.simulate

    def stopping(*args, sink, **kwargs):
        blocks = []

        def counting(block):
            if len(blocks) >= after_blocks:
                raise stop
            blocks.append(1)
            sink(block)

        return simulate(*args, sink=counting, **kwargs)

    monkeypatch.setattr(headless, "simulate", stopping)
    # long enough for two blocks of records (device.loop.engine.BLOCK_TICKS, 50 s)
    code, _, err = run(["run", "--code", patient, "--repetitions", "2", "--duration", "30"],
                       capsys)
    monkeypatch.setattr(headless, "simulate", simulate)
    # Ctrl-C is 130; an error no input should cause is an internal error (70), one line too
    assert code == {KeyboardInterrupt: 130, ValueError: 70}.get(type(stop), 2)
    assert err.count("\n") == 1, err
    rows, files = trials_and_files(data, patient)
    assert rows == expected[0]
    assert (files == []) if expected[1] == [] else (len(files) == expected[1])
    assert Registry(DataDir(data)).unfinished_trials() == []
    exports_cleanly(data, patient, capsys, tmp_path)


def test_take_back_is_what_the_window_calls_when_the_loop_refuses_a_start(data, patient):
    """The window registers at Start, then asks the loop: a refusal takes the row back."""
    from app.trials.registered import WITHDRAWN, take_back
    from core.trial import THESIS_SUBJECT

    registry = Registry(DataDir(data))
    begun = registry.begin_trial(patient, THESIS_SUBJECT, backend="simulator")
    assert take_back(registry, begun.trial_id, "the loop refused to start").outcome \
        == WITHDRAWN
    assert registry.trials_for_patient(patient) == []


@pytest.mark.parametrize("level", ["50", "100"])
def test_a_level_for_the_transparent_mode_is_refused_not_dropped(data, capsys, level):
    """The transparent mode has no level: a run asked for one would have run (and recorded)
    0 without a word; it is refused in one line, before anything is registered. Left out
    or 0, the run goes on."""
    code, _, err = run(["run", "--assist", "transparent", "--assistance", level, *SHORT],
                       capsys)
    assert code == 2
    assert err.count("\n") == 1
    assert "assistance" in err
    assert "transparent mode has no assistance level" in err


def test_a_folder_that_stops_taking_writes_after_its_check_fails_the_run_loudly(
        data, patient, capsys, tmp_path, monkeypatch, caplog):
    """The patient's folder is checked whole once a process (DataDir.ensure); a disk that
    then stops taking writes with its folders' modes unchanged (remounted read-only) is
    not seen at the next registration. The trial file's own creation fails: the run ends
    with one line saying why and what to do, the trial is withdrawn and the log says so."""
    import errno
    import logging

    from device.recording.trialfile import making
    from device.safewrite import OutputRefused

    code, _, err = run(["run", "--code", patient, *SHORT], capsys)
    assert code == 0, err

    def read_only(path):
        try:
            raise OSError(errno.EROFS, "Read-only file system", str(path))
        except OSError:
            raise OutputRefused(f"cannot create {path}: read-only file system") from None

    monkeypatch.setattr(making, "claim_private_file", read_only)
    with caplog.at_level(logging.WARNING):
        code, _, err = run(["run", "--code", patient, *SHORT], capsys)
    assert code == 2
    assert err.count("\n") == 1, err
    assert "permission denied: the console cannot write in" in err
    assert "the trial was not registered" in err
    assert "withdrawn, its file was never written" in caplog.text
    rows, files = trials_and_files(data, patient)
    assert rows == [("complete", True)]
    assert len(files) == 1
