"""A BIDS run's task is an assessment's task, else the exercise's shape, and its
TaskDescription the console's label of the exercise (mode, shape, controller): an
assessment's shape alone named the range, strength and reaching tasks all `targets`, and
every description said 'performance-based assistance', whatever the mode."""

from __future__ import annotations

import json

from tests.app.cli.running import run


def test_assessment_runs_are_named_by_their_task_and_every_run_by_its_mode(data, patient,
                                                                           tmp_path, capsys):
    for task in ("range", "strength"):
        code, _, err = run(["assess", "run", patient, "--task", task], capsys)
        assert code == 0, err
    code, _, err = run(["run", "--code", patient, "--repetitions", "1", "--seed", "2"], capsys)
    assert code == 0, err
    out = tmp_path / "bids"
    code, _, err = run(["export", "--patient", patient, "--format", "bids", "--output",
                        str(out)], capsys)
    assert code == 0, err
    sidecars = {path.name.split("_task-")[1].split("_")[0]: json.loads(path.read_text())
                for path in out.rglob("*_motion.json")}
    assert sorted(sidecars) == ["d", "range", "strength"]
    assert sidecars["strength"]["TaskName"] == "strength"
    strength = sidecars["strength"]["TaskDescription"]
    assert strength.startswith("Assessment: Isometric strength")
    assert "holds the handle still" in strength
    assert sidecars["d"]["TaskDescription"].startswith("As needed · D shape")
    assert not any("performance-based" in s["TaskDescription"] for s in sidecars.values())
