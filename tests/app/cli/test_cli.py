"""Every subcommand as a researcher or therapist types it: the happy path, and bad input
as one clear line with exit code 2, never a traceback."""

import csv
import io

import numpy as np
import pytest

from app.trials.reader import read_trial
from tests.app.cli.running import run


@pytest.fixture
def patient(data, capsys):
    code, out, _ = run(["patients", "add", "--first-name", "Wilhelmina", "--last-name",
                        "Quasthoff", "--body-mass", "80", "--upper-arm", "0.30", "--forearm",
                        "0.29", "--side", "right", "--shoulder", "-0.12", "0.73"], capsys)
    assert code == 0
    return out.strip()


def test_a_session_from_the_command_line(data, patient, capsys, tmp_path):
    code, out, _ = run(["patients"], capsys)
    assert code == 0
    assert patient in out
    assert "Quasthoff" in out
    _, out, _ = run(["patients", "--no-names"], capsys)
    assert "Quasthoff" not in out
    code, out, _ = run(["run", "--code", patient, "--repetitions", "1"], capsys)
    assert code == 0
    assert "Registered as patient" in out
    code, out, _ = run(["trials", patient], capsys)
    assert code == 0
    assert "complete" in out
    code, out, _ = run(["progress", patient], capsys)
    assert code == 0
    assert "RMSE x" in out
    code, out, _ = run(["progress", patient, "--csv"], capsys)
    assert out.splitlines()[0].startswith("trial_id,")
    header, first = list(csv.reader(io.StringIO(out)))[:2]
    columns = dict(zip(header, first, strict=True))
    assert (columns["exercise"], columns["assistance_mode"],
            columns["assistance_changes"]) == ("1", "as-needed", "[]")
    assert len(columns) == len(header)  # no column twice
    code, out, _ = run(["progress", patient, "--pdf", str(tmp_path / "progress.pdf")],
                       capsys)
    assert code == 0
    assert out.splitlines()[0] == str(tmp_path / "progress.pdf")
    assert "As needed · D shape" in out
    code, _, err = run(["progress", patient, "--pdf", str(tmp_path / "progress.pdf")],
                       capsys)
    assert code == 2
    assert "progress.pdf already exists and is kept" in err
    code, out, _ = run(["report", "1"], capsys)
    assert code == 0
    assert out.strip().endswith(".pdf")
    code, out, _ = run(["export", "--patient", patient, "--format", "tsv", "--output",
                        str(tmp_path / "export")], capsys)
    assert code == 0
    assert "exported 1 trial" in out
    # the registered trial's file carries the metrics the registry holds
    trial_file = next((data / "trials" / patient).glob("*.h5"))
    assert "rmse_x_m" in read_trial(trial_file).metrics
    # no name in any file or path the commands wrote
    for path in data.rglob("*"):
        assert "Quasthoff" not in str(path)
        if path.is_file() and path.suffix != ".sqlite3" and "sqlite3" not in path.name:
            assert b"Quasthoff" not in path.read_bytes(), path


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["run", "--patient", "zombie"], "invalid choice"),
        (["run", "--repetitions", "0"], "repetitions"),
        (["run", "--code", "P000000"], "P000000"),
        (["patients", "add", "--body-mass", "-5"], "body"),
        (["patients", "add", "--side", "middle"], "invalid choice"),
        (["trials", "P000000"], "P000000"),
        (["progress", "P000000"], "P000000"),
        (["report", "999"], "999"),
        (["report", "abc"], "invalid int"),
        (["export", "--trial", "999"], "999"),
        (["export", "--format", "csv"], "required"),
        (["export", "--patient", "P000000", "--format", "xls"], "invalid choice"),
        (["nonsense"], "invalid choice"),
        (["run", "--assist", "lots"], "invalid choice"),
        (["report", "99999999999999999999999"], "not a trial id"),
        (["report", "0"], "not a trial id"),
        (["export", "--trial", "99999999999999999999999", "--format", "csv"], "not a trial id"),
        (["export", "--folder", "", "--format", "csv"], "--folder is empty"),
        (["run", "--plant", "perfect"], "invalid choice"),
        (["run", "--gains", "smc.lambda_1_s=500"], "smc.lambda_1_s[0]"),
        (["check", "--gains", "pid.kp=3"], "no gains called 'pid'"),
        (["reanalyse"], "one of the arguments --patient --all is required"),
        (["reanalyse", "--patient", "P000000", "--all"], "not allowed with argument"),
        (["reanalyse", "--all", "--session", "1", "--dry-run"], "--session needs --patient"),
        (["reanalyse", "--patient", "nobody", "--dry-run"], "is not a patient code"),
        (["reanalyse", "--patient", "P000000", "--dry-run"], "P000000"),
        (["reanalyse", "--all"], "--by is missing"),
        (["reanalyse", "--all", "--by", "  "], "--by is missing"),
        (["reanalyse", "--all", "--by", "x" * 101], "--by has 101 characters"),
        (["reanalyse", "--patient", "P000000", "--session", "0", "--dry-run"],
         "give a session number from 1"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(data, patient, capsys, args, needle):
    code, _, err = run(args, capsys)
    assert code == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert needle in lines[0]
    assert "Traceback" not in err


def test_unknown_metric_in_progress_is_refused(data, patient, capsys):
    run(["run", "--code", patient, "--repetitions", "1"], capsys)
    code, _, err = run(["progress", patient, "--metric", "happiness"], capsys)
    assert code == 2
    assert "unknown metric 'happiness'" in err


def test_progress_shows_an_assessment_figure_with_its_digits(data, patient, capsys):
    """`rehab progress --metric` with the assessment's figure keys: printed with one
    decimal in SI units, a position error of 0.033 m was 0.0 and a movement time of 1.007 s
    1.0, and two long keys ran together in the heading. In the therapist's table's unit
    (mm), not SI."""
    from app.records.datadir import DataDir
    from app.records.registry import Registry
    from core.assessment import FIGURES

    code, _, err = run(["assess", "run", patient, "--task", "position", "--patient", "weak",
                        "--seed", "1"], capsys)
    assert code == 0, err
    keys = ["position_absolute_error_m", "position_variable_error_m"]
    code, out, err = run(["progress", patient, *(f"--metric={k}" for k in keys)], capsys)
    assert code == 0, err
    lines = out.splitlines()
    # an assessment's series: its runs a column each, its figures a line each
    heading = next(line for line in lines if line.startswith("figure"))
    assert heading.split() == ["figure", "S1", "T1"]
    (trial,) = Registry(DataDir(data)).trials_for_patient(patient)
    for key in keys:
        row = next(line for line in lines if line.startswith(FIGURES[key].label + "  "))
        assert FIGURES[key].unit == "m"
        assert row.endswith(f"{trial.metrics[key] * 1000.0:.4g} mm"), (key, row)
        assert 0.001 < trial.metrics[key] < 0.1


def test_help_lists_every_command(capsys):
    code, out, _ = run(["--help"], capsys)
    assert code == 0
    for command in ("check", "run", "patients", "trials", "progress", "report", "export",
                    "gains"):
        assert command in out


def test_run_chooses_the_assistance_and_the_plant_and_prints_who_did_the_work(data, capsys,
                                                                          tmp_path):
    code, out, _ = run(["run", "--repetitions", "1", "--output", str(tmp_path / "a.h5")],
                       capsys)
    assert code == 0
    assert "realistic plant, as-needed assistance" in out  # the defaults
    for label in ("Robot's net work", "Patient's net work", "Robot's share of the work"):
        assert label in out
    trial = read_trial(tmp_path / "a.h5")
    assert trial.parameters.assist == "as-needed"
    code, out, _ = run(["run", "--repetitions", "1", "--assist", "thesis", "--plant", "ideal",
                        "--output", str(tmp_path / "b.h5")], capsys)
    assert code == 0
    assert "ideal plant, thesis assistance" in out
    assert read_trial(tmp_path / "b.h5").parameters.assist == "thesis"


def test_a_researcher_lists_the_gains_and_runs_a_trial_with_changed_ones(data, capsys,
                                                                        tmp_path):
    code, out, _ = run(["gains"], capsys)
    assert code == 0
    assert "smc.lambda_1_s" in out
    assert "guidance.delay_s" in out
    code, out, _ = run(["run", "--repetitions", "1", "--gains", "guidance.delay_s=0.6",
                        "--output", str(tmp_path / "g.h5")], capsys)
    assert code == 0
    assert read_trial(tmp_path / "g.h5").parameters.gains == "guidance.delay_s=0.6"


def test_a_report_never_overwrites_a_file_it_was_not_asked_to(data, patient, capsys,
                                                            tmp_path):
    run(["run", "--code", patient, "--repetitions", "1"], capsys)
    registry_file = data / "registry.sqlite3"
    before = registry_file.stat().st_size
    code, _, err = run(["report", "1", "--output", str(registry_file)], capsys)
    assert code == 2
    assert ".pdf" in err
    code, _, err = run(["report", "1", "--output", str(data / "trials" / "x.pdf")], capsys)
    assert code == 2
    assert "inside the data folder" in err
    assert registry_file.stat().st_size >= before
    code, out, _ = run(["patients"], capsys)
    assert patient in out  # every patient is still there
    existing = tmp_path / "mine.pdf"
    existing.write_bytes(b"the therapist's own file")
    code, _, err = run(["report", "1", "--output", str(existing)], capsys)
    assert code == 2
    assert "already exists" in err
    assert existing.read_bytes() == b"the therapist's own file"
    code, out, _ = run(["report", "1", "--output", str(existing), "--force"], capsys)
    assert code == 0
    assert existing.read_bytes().startswith(b"%PDF")


def test_a_reader_that_goes_away_is_not_an_error(tmp_path):
    """`rehab … | head`: the pipe closes under the command; it ends quietly, exit 0."""
    import subprocess
    import sys

    script = ("import os, sys\n"
              "r, w = os.pipe(); os.close(r); os.dup2(w, 1)\n"
              "from app.cli.main import main\n"
              "sys.exit(main(['gains']))\n")
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                          timeout=120, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert "Traceback" not in done.stderr
    assert done.stderr == ""


@pytest.mark.parametrize("where", ["before", "after", "after_the_action"])
def test_data_dir_is_taken_before_or_after_the_command(tmp_path, monkeypatch, capsys, where):
    monkeypatch.delenv("REHAB_DATA_DIR", raising=False)
    monkeypatch.setenv("REHAB_CONFIG_DIR", str(tmp_path / "config"))
    folder = str(tmp_path / "elsewhere")
    add = ["patients", "add", "--first-name", "Ada", "--last-name", "Example",
           "--body-mass", "70"]
    argv = {"before": ["--data-dir", folder, *add], "after": [*add[:1], "--data-dir", folder,
                                                             *add[1:]],
            "after_the_action": [*add, "--data-dir", folder]}[where]
    code, out, err = run(argv, capsys)
    assert code == 0, err
    assert (tmp_path / "elsewhere" / "registry.sqlite3").exists()
    code, listed, _ = run(["patients", "list", "--data-dir", folder], capsys)
    assert code == 0
    assert out.strip() in listed


def test_a_full_disk_registers_nothing_and_says_so_in_one_line(data, patient, capsys,
                                                               monkeypatch):
    """A refused `rehab run --code` used to leave a trial 'recording' with no file."""
    from app.records.datadir import DataDir
    from app.records.registry import Registry
    from device.recording.trialfile import writer

    monkeypatch.setattr(writer, "_free_bytes", lambda folder: 1024)  # 1 KiB free
    code, _, err = run(["run", "--code", patient, "--repetitions", "1"], capsys)
    assert code == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1
    assert "free" in lines[0]
    assert "not registered" in lines[0]
    assert Registry(DataDir(data)).trials_for_patient(patient) == []
    assert not list((data / "trials").rglob("*.h5"))


def test_a_registered_run_is_analysed_once(data, patient, capsys, monkeypatch):
    """`rehab run --code` used to analyse the trial twice: in the run, then again when
    registering it. The registry takes the run's figures."""
    from app.records.datadir import DataDir
    from app.records.registry import Registry

    def again(data):
        raise AssertionError("the trial was analysed a second time")

    monkeypatch.setattr("app.trials.finalize.analyse_data", again)
    code, _out, err = run(["run", "--code", patient, "--repetitions", "1"], capsys)
    assert code == 0, err
    trial, = Registry(DataDir(data)).trials_for_patient(patient)
    assert trial.status == "complete"
    from app.trials.reader import read_trial

    stored = read_trial(Registry(DataDir(data)).trial_path(trial), ()).metrics
    assert trial.metrics["rmse_x_m"] > 0.0
    assert trial.metrics.keys() == stored.keys()
    np.testing.assert_equal(list(trial.metrics.values()), [stored[k] for k in trial.metrics])


def test_trials_lists_why_a_trial_ended_and_the_radius_in_cm(data, patient, capsys):
    """The set-up's sizes in cm as the form shows them (issue 13 #6: the list said
    'r 100 mm'); a trial that did not complete says why under its row (#18)."""
    from app.records.datadir import DataDir
    from app.records.registry import Registry
    from core.trial import THESIS_SUBJECT

    registry = Registry(DataDir(data))
    begun = registry.begin_trial(patient, THESIS_SUBJECT, backend="simulator")
    registry.finish_trial(begun.trial_id, "recording_lost", {},
                          reason="the disk is full: free some space")
    code, out, _ = run(["trials", patient], capsys)
    assert code == 0
    assert "r 10.0 cm" in out
    assert " mm," not in out
    assert "ended: the disk is full: free some space" in out


def test_a_second_patient_of_a_registered_name_needs_same_name(tmp_path, capsys):
    """`patients add` registered a second "Ada Example" without a word (the Registration
    tab asks first): the same person twice splits their record in two."""
    base = ["--data-dir", str(tmp_path / "d"), "patients", "add", "--first-name", "Ada",
            "--last-name", "Example"]
    code, first, _ = run([*base, "--birth-year", "1950"], capsys)
    assert code == 0
    code, _, err = run(base, capsys)
    assert code == 2
    assert err.strip() == (f"rehab patients add: error: already registered: {first.strip()} "
                           "(Example, Ada, born 1950). Use that code, or give --same-name to "
                           "register a different person with this name")
    code, second, _ = run([*base, "--same-name"], capsys)
    assert code == 0
    assert second != first
