"""The corruption test (issue 28): every file type the console reads, damaged (bit flips in
metadata and data, set bytes, zeroed blocks, truncations) and edited (h5py edits with and
without their seal made again, links, huge claimed sizes, edited and rehashed models,
CSV lines over 131 KB, NaN, time backwards, deep JSON), read by every reader of its type
in a worker process with a time limit per file (tests/corruption.py). None may load other
data silently, hang or end in a traceback. bench/corruption.py runs ≥ 10³ such files."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from tests import corruption

SEED = 28


@pytest.fixture(scope="module")
def results(tmp_path_factory, emg_subject_1, emg_model_1):
    folder = tmp_path_factory.mktemp("corruption")
    # subject 1's session and model as the run made them once (tests/conftest.py), copied
    originals = corruption.make_originals(folder / "originals", session=emg_subject_1,
                                          checked=emg_model_1)
    cases = corruption.make_cases(originals, folder / "cases", per_file=2, seed=SEED)
    config = Path(os.environ["REHAB_CONFIG_DIR"])  # whose key signed the models
    return corruption.run(cases, timeout_s=30.0, env=corruption.environment(config))


def listed(results, outcome) -> list[str]:
    return [f"{r.case.kind}: {r.case.how}: {r.detail}" for r in results if r.outcome == outcome]


def test_every_file_type_is_covered(results):
    kinds = {r.case.kind for r in results}
    assert kinds == {"trial", "model", "emg-model", "emg-csv", "mvc-csv", "settings",
                     "registry", "video", "timestamps"}
    assert len(results) >= 100


def test_no_corrupted_file_hangs_a_reader(results):
    assert listed(results, "hang") == []


def test_no_corrupted_file_ends_in_a_traceback(results):
    assert listed(results, "crash") == []


def test_no_sealed_or_signed_file_loads_other_data_silently(results):
    assert listed(results, "silent") == []
    # with a note, of the checked kinds: only a trial whose seal was taken away, read as
    # "closing interrupted"; of the others, what the reader says it did (settings set
    # aside as .corrupt-<time>, an EMG export's channels cut to the shortest)
    noted = [r for r in results if r.outcome == "noted" and r.case.kind in
             corruption.CHECKED_KINDS]
    assert all(r.case.how == "h5py edit: seal deleted" and "unsealed" in r.detail
               for r in noted), listed(results, "noted")
    assert all(r.detail.startswith("set aside as ") for r in results
               if r.outcome == "noted" and r.case.kind == "settings")


def test_every_refusal_names_the_file_it_refuses(results):
    """Issue 28: one line saying what is wrong, of which file (a reader of many files, an
    export of a patient's trials, must say which one it refused)."""
    assert [f"{r.case.kind}: {r.case.how}: {r.detail}"
            for r in corruption.unnamed(results)] == []


def test_the_edits_the_issue_found_are_refused(results):
    refused = {r.case.how for r in results if r.outcome == "refused"}
    for how in ("h5py edit: external link", "h5py edit: virtual dataset",
                "h5py edit: events 10^8 rows", "h5py edit: phase 7 (sealed again)",
                "h5py edit: position int32 (sealed again)", "h5py edit: subject code",
                "h5py edit: status bomplete", "h5py edit: emg 5 columns for 3 (sealed again)",
                "h5py edit: mvc flags text (sealed again)",
                "h5py edit: emg notes cut (sealed again)", "edit: cone narrowed, rehashed",
                "edit: weight changed, rehashed", "edit: weight 1e308, signed",
                "edit: a line of 200 KB", "edit: header only",
                "sqlite3 edit: patient's name (triggers dropped)", "sqlite3 edit: seal swapped",
                "sqlite3 edit: trial's status (triggers dropped)",
                "sqlite3 edit: trial's metric (triggers dropped)", "edit: data_dir 123",
                "edit: data_dir empty", "edit: nested 200k deep"):
        assert how in refused, how
