"""A researcher analyses a department's study through the research role (issue 32, "Roles":
exports made through the research role can never include names): the console's registry on
a researcher's login reads codes and data, the server keeping every name and typed text
from it, and `rehab study analyse` then writes no name anywhere."""

from __future__ import annotations

import dataclasses

import pytest

from app.records.datadir import DataDir
from app.records.registry import Registry
from tests.app.cli.running import run

NAMES = ("Zebulon", "Quintavius", "K. Lee", "tired today", "let go of the handle", "room 2")


def point(url, config) -> None:
    path = config / "registry.url"
    path.write_text(url.render_as_string(hide_password=False) + "\n")
    path.chmod(0o600)


@pytest.fixture
def study_on_the_server(data, tmp_path, server_registries, capsys, monkeypatch):
    """Two patients registered and two trials run each, through a station's clinic login
    (the commands read the URL file) on the station robot-3, one trial marked invalid and
    noted."""
    monkeypatch.setenv("REHAB_STATION", "robot-3")
    url = server_registries.new()
    config = tmp_path / "config"
    config.mkdir(mode=0o700, exist_ok=True)
    point(url, config)
    codes = []
    for first, last in (("Zebulon", "Quintavius"), ("Bo", "Other")):
        code, out, err = run(["patients", "add", "--first-name", first, "--last-name", last,
                              "--body-mass", "70", "--upper-arm", "0.30", "--forearm", "0.29",
                              "--side", "right", "--shoulder", "-0.12", "0.73"], capsys)
        assert code == 0, err
        codes.append(out.strip())
        for shape in ("d", "circle"):
            code, _, err = run(["run", "--code", codes[-1], "--repetitions", "1",
                                "--trajectory", shape, "--seed", "3"], capsys)
            assert code == 0, err
    clinic = Registry(DataDir(data), server=url, station="robot-1")
    first = clinic.trials_for_patient(codes[0])
    clinic.mark_trial(first[1].id, valid=False, reason="let go of the handle", by="K. Lee")
    clinic.add_note(codes[0], 1, "tired today", author="K. Lee")
    return url, config, codes, clinic


def test_a_researchers_login_reads_codes_and_data_and_changes_nothing(
        study_on_the_server, server_registries, data):
    url, _, codes, clinic = study_on_the_server
    research = Registry(DataDir(data), server=server_registries.as_researcher(url))
    assert research.research
    assert research.location().startswith("research login (codes and data) · shared")
    patients = sorted(research.patients(), key=lambda p: p.code)
    assert [p.code for p in patients] == sorted(codes)
    assert {(p.first_name, p.last_name, p.display_name) for p in patients} == {
        ("", "", p.code) for p in patients}
    assert [p.body_mass_kg for p in patients] == [70.0, 70.0]
    for code in codes:
        # the same trials, each the same but for why one was marked invalid: withheld
        theirs = clinic.trial_summaries(code, include_invalid=True)
        assert research.trial_summaries(code, include_invalid=True) == [
            s if s.invalid_reason is None else dataclasses.replace(
                s, invalid_reason="withheld from research") for s in theirs]
        assert research.trial_summaries(code) == clinic.trial_summaries(code)
        assert [t.metrics for t in research.trials_for_patient(code)] == \
            [t.metrics for t in clinic.trials_for_patient(code)]
    (note,) = research.notes(codes[0])
    assert (note.text, note.author) == ("", "")
    assert [m.reason for m in research.invalid_trials(codes[0]).values()] == [
        "withheld from research"]
    with pytest.raises(Exception, match="is a researcher's: it reads codes and data, never "
                                        "names, and changes nothing; nothing was changed"):
        research.create_patient("Eve", "Intruder")
    assert "Eve" not in {p.first_name for p in clinic.patients()}


def test_a_study_analysed_through_the_research_role_holds_no_name(
        study_on_the_server, server_registries, data, tmp_path, client, capsys):
    url, config, codes, _ = study_on_the_server
    point(server_registries.as_researcher(url), config)
    out_folder = tmp_path / "study"
    code, out, err = run(["study", "analyse", "all", "--output", str(out_folder),
                          "--scheduler", client.scheduler.address, "--include-invalid"],
                         capsys)
    assert code == 0, err
    assert "analysed 4 trial(s)" in out
    written = [path for path in out_folder.rglob("*") if path.is_file()]
    assert written
    text = b"".join(path.read_bytes() for path in written)
    for code_ in codes:
        assert code_.encode() in text
    trials = (out_folder / "trials.csv").read_text()
    assert trials.count(",robot-3,") == 4  # each trial's site: the station that recorded it
    for name in NAMES:
        assert name.encode() not in text, name
