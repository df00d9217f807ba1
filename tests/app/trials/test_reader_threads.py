"""A trial file that fails to read half-way through its attributes leaves h5py free for
the console's other threads (device.recording.h5views): h5py's views hold its global lock
across each item, so a reader that raised between two items, its exception still alive
(a Future keeps a job's), held that lock, and a window's job thread finishing a trial
deadlocked on it."""

import threading

import pytest

import app.trials.reader as reader
from app.errors import AppError
from app.trials.headless import save, simulate
from core.trial import THESIS_SUBJECT
from tests.patience import HANG_S


@pytest.fixture(scope="module")
def trial(tmp_path_factory):
    path = tmp_path_factory.mktemp("threads") / "trial.h5"
    save(simulate(THESIS_SUBJECT.replace(repetitions=1), seed=1), path)
    return path


def _another_thread_reads(path) -> bool:
    """Whether a second thread can read the file's attributes (h5py's lock is free)."""
    done = threading.Event()

    def read():
        reader.read_groups(path)
        done.set()

    threading.Thread(target=read, daemon=True).start()
    return done.wait(HANG_S)


def test_a_read_that_failed_mid_attributes_holds_no_lock(trial, monkeypatch):
    real = reader.plain_attribute
    calls = {"n": 0}

    def failing(value):
        calls["n"] += 1
        if calls["n"] == 2:  # the file's second attribute
            raise ValueError("unreadable attribute")
        return real(value)

    monkeypatch.setattr(reader, "plain_attribute", failing)
    with pytest.raises(AppError) as kept:  # the exception, its traceback alive
        reader.read_groups(trial)
    monkeypatch.setattr(reader, "plain_attribute", real)
    assert "unreadable attribute" in str(kept.value)
    assert _another_thread_reads(trial)
