"""Stored trials re-analysed from their files (app.trials.reanalyse, `rehab reanalyse`), on
both of the registry's engines: a trial analysed before the robot's share of the work
counted its help alone (no robot_help_work_J; its share read as NaN) gets today's figures in
the registry with a note saying which analysis made them; its file is never written; a
trial whose file is missing or changed is listed with why and skipped; a second run changes
nothing; a trial marked invalid stays invalid."""

from __future__ import annotations

import math
import shutil
from functools import cache

import pytest

from app.errors import RegistryError
from app.records.registry.provenance import file_checksum
from app.trials.analysis import ANALYSIS
from app.trials.finalize import finalize_trial
from app.trials.headless import save, simulate
from app.trials.reanalyse import CHANGED, SKIPPED, UNCHANGED, reanalyse, trials_of
from core.trial import THESIS_SUBJECT
from device.recording.trialfile import software_version
from tests.old_analysis import analysed_as_before

PARAMS = THESIS_SUBJECT.replace(repetitions=1, assist="transparent")


@cache
def _simulated():
    return simulate(PARAMS, patient="healthy", seed=0)


@pytest.fixture(scope="module")
def old_file(tmp_path_factory):
    """A trial file as the console wrote it before the help's work was a metric."""
    path = tmp_path_factory.mktemp("old") / "old.h5"
    with pytest.MonkeyPatch.context() as patch:
        analysed_as_before(patch)
        save(_simulated(), path)
    return path


def _old_trial(registry, code, old_file):
    """A trial registered and finished by the console before the change."""
    begun = registry.begin_trial(code, PARAMS, backend="simulator")
    shutil.copyfile(old_file, begun.path)
    with pytest.MonkeyPatch.context() as patch:
        analysed_as_before(patch)
        finalize_trial(registry, begun.trial_id)
    return registry.trial(begun.trial_id)


@pytest.mark.changes_recorded_files  # one file changed on purpose: it is skipped
def test_old_trials_get_todays_figures_and_their_files_stay_as_they_were(open_registry,
                                                                         old_file):
    registry = open_registry()
    code = registry.create_patient("Ada", "Lovelace").code
    kept, invalid, missing, changed = (_old_trial(registry, code, old_file)
                                       for _ in range(4))
    registry.mark_trial(invalid.id, valid=False, reason="patient sneezed", by="T. Ward")
    registry.trial_path(missing).unlink()
    with open(registry.trial_path(changed), "r+b") as file:  # a byte changed on the disk
        file.seek(4096)
        byte = file.read(1)
        file.seek(4096)
        file.write(bytes([byte[0] ^ 0xFF]))
    assert math.isnan(kept.metrics["robot_work_share"])
    assert "robot_help_work_J" not in kept.metrics
    sums = {t.id: file_checksum(registry.trial_path(t)) for t in (kept, invalid, changed)}

    listed = reanalyse(registry, trials_of(registry, code), dry_run=True)
    assert [o.result for o in listed] == [CHANGED, CHANGED, SKIPPED, SKIPPED]
    assert not any(o.stored for o in listed)
    assert "missing" in listed[2].reason
    assert "is not the file recorded" in listed[3].reason
    figures = dict((key, (old, new)) for key, old, new in listed[0].changes)
    assert set(figures) == {"robot_help_work_J", "robot_work_share"}
    assert math.isnan(figures["robot_work_share"][0])
    assert figures["robot_work_share"][1] <= 0.01  # a transparent trial gives no help
    assert "would change 2 figure(s): robot_work_share none → 0; robot_help_work_J none → " \
        in listed[0].line()
    assert registry.trial(kept.id).metrics.keys() == kept.metrics.keys()
    assert registry.notes(code) == []

    done = reanalyse(registry, trials_of(registry, code), by="R. Searcher")
    assert [(o.result, o.stored) for o in done] == [(CHANGED, True), (CHANGED, True),
                                                    (SKIPPED, False), (SKIPPED, False)]
    for trial in (kept, invalid):
        now = registry.trial(trial.id)
        assert now.metrics["robot_work_share"] == figures["robot_work_share"][1]
        assert now.metrics["robot_help_work_J"] == figures["robot_help_work_J"][1]
        assert now.metrics["rmse_x_m"] == trial.metrics["rmse_x_m"]
        assert now.checksum == trial.checksum
    assert {t: file_checksum(registry.trial_path(t)) for t in sums} == sums
    notes = registry.notes(code)
    assert [(n.trial_id, n.author) for n in notes] == [(kept.id, "R. Searcher"),
                                                       (invalid.id, "R. Searcher")]
    assert f"analysis of {ANALYSIS} (rehab-console {software_version()}" in notes[0].text
    assert "robot_work_share none → " in notes[0].text
    assert invalid.id in registry.invalid_trials(code)  # still invalid

    again = reanalyse(registry, trials_of(registry, code), by="R. Searcher")
    assert [o.result for o in again] == [UNCHANGED, UNCHANGED, SKIPPED, SKIPPED]
    assert len(registry.notes(code)) == 2
    assert trials_of(registry, code, 1) == registry.trials(code, 1)


def test_figures_changed_meanwhile_are_not_overwritten(open_registry, old_file):
    """The update is made against the figures the analysis started from, with its note, in
    one transaction: another station's change meanwhile refuses it, and nothing is kept."""
    registry = open_registry()
    code = registry.create_patient("Ada", "Lovelace").code
    trial = _old_trial(registry, code, old_file)
    registry.update_metrics(trial.id, {"circle_ratio": 0.9})
    with pytest.raises(RegistryError, match="changed while it was re-analysed"):
        registry.record_reanalysis(trial.id, trial.metrics, {"rmse_x_m": 0.0}, "n", by="b")
    assert registry.trial(trial.id).metrics["circle_ratio"] == 0.9
    assert registry.trial(trial.id).metrics["rmse_x_m"] == trial.metrics["rmse_x_m"]
    assert registry.notes(code) == []
    # the figures the analysis does not make (an assessment's of both ways) are kept
    (outcome,) = reanalyse(registry, [registry.trial(trial.id)], by="R. Searcher")
    assert outcome.stored
    assert registry.trial(trial.id).metrics["circle_ratio"] == 0.9
