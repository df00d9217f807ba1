"""The window's job thread as the window closes (ui.jobs)."""

from __future__ import annotations

from ui.jobs import Jobs


def test_a_job_given_after_shutdown_is_not_run_and_raises_nothing(qtbot):
    """Found closing the window mid-trial: the trial was finished into the registry while
    the window closed (Jobs.shutdown waits for it), and its callback, delivered after,
    asked for one more job (the file read for the live tabs): "RuntimeError: cannot
    schedule new futures after shutdown" on the console. Now a job given after shutdown
    is not run, quietly."""
    jobs = Jobs()
    results = []
    jobs.run(lambda: "finished", results.append)
    jobs.shutdown()
    qtbot.waitUntil(lambda: results == ["finished"], timeout=5000)  # given before: run
    ran_after = []
    jobs.run(lambda: ran_after.append(True), ran_after.append)  # raised here before
    qtbot.wait(50)
    assert ran_after == []


def test_settled_runs_before_the_callback_and_before_a_failure_is_said(qtbot):
    """What waits for a job (the next Start for a trial's finish) is told it ended whether it
    succeeded or failed; a failed job's callback is not called."""
    jobs = Jobs()
    said = []
    jobs.failed.connect(lambda error: said.append(("failed", str(error))))
    jobs.run(lambda: "finished", lambda result: said.append(("callback", result)),
             settled=lambda: said.append(("settled", None)))

    def fails():
        raise RuntimeError("disk full")

    jobs.run(fails, lambda result: said.append(("callback", result)),
             settled=lambda: said.append(("settled", None)))
    qtbot.waitUntil(lambda: len(said) == 4, timeout=5000)
    assert said == [("settled", None), ("callback", "finished"), ("settled", None),
                    ("failed", "disk full")]
    jobs.shutdown()
