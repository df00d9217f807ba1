"""Consoles started at the same moment on a new data folder: none takes the registry another
is making for a damaged one (issue 28 #7: 5 of 32 processes refused with a false "registry
… empty (0 bytes)", a `.damaged-*` copy left, their patients not registered).

The registry is made whole in a temporary file and linked into place
(app.records.registry.schema.create_registry_file), so a console sees no registry or a
whole one. Several processes, released together by a barrier, each open the registry and
register a patient; every round, in a fresh folder, all must succeed.
"""

from __future__ import annotations

import multiprocessing
import warnings
from pathlib import Path

from app.records.datadir import DataDir
from app.records.registry import Registry

PROCESSES = 6
ROUNDS = 6


def _first_start(root: str, barrier, results, index: int) -> None:
    try:
        barrier.wait(timeout=60)
        registry = Registry(DataDir(Path(root)))
        registry.create_patient(f"Ada{index}", "Example", birth_year=1950)
        results.put((index, ""))
    except BaseException as exc:  # reported to the test, whatever it is
        results.put((index, f"{type(exc).__name__}: {exc}"))


def test_consoles_opening_a_new_data_folder_at_once_all_find_a_sound_registry(tmp_path):
    context = multiprocessing.get_context("fork")
    failures = []
    for round_ in range(ROUNDS):
        root = tmp_path / f"round{round_}" / "data"
        barrier = context.Barrier(PROCESSES)
        results = context.Queue()
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", r".*multi-threaded.*fork", DeprecationWarning)
            # JAX warns likewise when a test before this one in the same worker loaded it
            # (pytest-xdist deals files out in any order); the child never touches JAX
            warnings.filterwarnings("ignore", r"os\.fork\(\) was called", RuntimeWarning)
            workers = [context.Process(target=_first_start, args=(str(root), barrier, results, i))
                       for i in range(PROCESSES)]
            for worker in workers:
                worker.start()
        outcomes = dict(results.get(timeout=120) for _ in workers)
        for worker in workers:
            worker.join(60)
        failures += [f"round {round_}, console {i}: {why}" for i, why in outcomes.items() if why]
        assert root.is_dir(), failures
        assert sorted(p.name for p in root.iterdir() if ".damaged-" in p.name) == []
        assert not [p for p in root.iterdir() if p.name.startswith(".rehab-")]
        if not failures:
            assert len(Registry(DataDir(root)).patients()) == PROCESSES
    assert failures == []
