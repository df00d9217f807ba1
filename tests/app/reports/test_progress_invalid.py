"""Progress leaves a trial marked invalid out and shows it, with why, when asked
(issue 31: `rehab progress --include-invalid`, the Progress tab's tick box)."""

from app.records.datadir import DataDir
from app.records.registry import Registry
from app.reports.progress import progress
from core.trial import THESIS_SUBJECT
from tests.app.cli.running import run


def test_an_invalid_trial_leaves_progress_and_comes_back_when_asked(tmp_path, capsys,
                                                                    monkeypatch):
    monkeypatch.setenv("REHAB_DATA_DIR", str(tmp_path / "data"))
    monkeypatch.setenv("REHAB_CONFIG_DIR", str(tmp_path / "config"))
    registry = Registry(DataDir(tmp_path / "data"))
    code = registry.create_patient("Ada", "Example").code
    ids = []
    for rmse in (0.010, 0.050, 0.008):
        begun = registry.begin_trial(code, THESIS_SUBJECT, backend="simulator")
        registry.finish_trial(begun.trial_id, "complete", {"rmse_x_m": rmse})
        ids.append(begun.trial_id)
    registry.mark_trial(ids[1], valid=False, reason="the robot was bumped", by="K. Lee")

    shown = progress(registry, code, check_files=False)
    assert [t.id for t in shown.trials] == [ids[0], ids[2]]
    assert list(shown.values["rmse_x_m"]) == [0.010, 0.008]

    every = progress(registry, code, check_files=False, include_invalid=True)
    header, rows = every.table()
    column = header.index("invalid_reason")
    assert [(r[0], r[column]) for r in rows] == [(ids[0], ""), (ids[1], "the robot was bumped"),
                                                 (ids[2], "")]

    _, out, _ = run(["progress", code], capsys)
    assert "2 trials" in out
    assert "INVALID" not in out
    _, out, _ = run(["progress", code, "--include-invalid"], capsys)
    assert "3 trials, 1 exercise\n" in out
    # the table says which row is invalid, and why (it used to show it as 'complete')
    (row,) = [line for line in out.splitlines() if line.split()[:2] == ["1", "2"]]
    assert row.split()[2] == "INVALID"
    assert (f"  session 1 trial 2 (id {ids[1]}) marked invalid: the robot was bumped"
            in out)

    registry.mark_trial(ids[1], valid=True, reason="replayed: fine", by="K. Lee")
    assert [t.id for t in progress(registry, code, check_files=False).trials] == ids


def test_a_trials_report_never_compares_with_a_trial_marked_invalid(tmp_path):
    from app.reports.build import earlier_like

    registry = Registry(DataDir(tmp_path / "data"))
    code = registry.create_patient("Ada", "Example").code
    ids = []
    for session in (1, 2, 2):
        begun = registry.begin_trial(code, THESIS_SUBJECT, backend="simulator",
                                     session_number=session)
        registry.finish_trial(begun.trial_id, "complete", {"rmse_x_m": 0.01})
        ids.append(begun.trial_id)
    latest = registry.trial(ids[2])
    assert [t.id for t in earlier_like(registry, latest)] == [ids[1], ids[0]]
    registry.mark_trial(ids[1], valid=False, reason="the robot was bumped", by="K. Lee")
    assert [t.id for t in earlier_like(registry, latest)] == [ids[0], ids[0]]
