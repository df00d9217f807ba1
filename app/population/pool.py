"""Work on many subjects spread over worker processes.

`map_subjects(work, subjects, workers)` runs `work(subject)` for every subject and returns
the results in the subjects' order, whatever the order the workers finished in: a
population's results do not depend on how many processes built them. The workers are
spawned (a fresh interpreter each: nothing of the caller's threads or open files is
inherited) and each loads the compiled kernels once from the cache (device.compiled): a
worker's start costs about 2 s of CPU once (imports, the kernels, its first visit), and a
task after that only the pickles of its subjects and results, milliseconds. So a batch is
cut into CHUNKS_PER_WORKER chunks a worker: few enough that the tasks cost nothing, many
enough that the last chunks finish together (with 4 a worker, a population of 1,000
battery visits went in chunks of 125, about a minute each, and one worker could sit idle
for most of the last one). `workers` 1 runs in this process (the tests' and the reference
way).
"""

from __future__ import annotations

import math
import multiprocessing
import os
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor

from core.errors import ParameterError

MAX_WORKERS = 64
CHUNKS_PER_WORKER = 16


def check_workers(workers) -> int:
    """A worker count: a whole number from 1 to MAX_WORKERS."""
    if isinstance(workers, bool) or not isinstance(workers, int) or not 1 <= workers <= MAX_WORKERS:
        raise ParameterError("workers", workers, f"a whole number from 1 to {MAX_WORKERS}",
                             f"this machine has {os.cpu_count()} CPUs")
    return workers


def _run_chunk(work: Callable, chunk: Sequence) -> list:
    return [work(item) for item in chunk]


def map_subjects(work: Callable, subjects: Sequence, workers: int = 2) -> list:
    """[work(s) for s in subjects], over `workers` processes (`work` must be a module-level
    function, picklable, as the subjects)."""
    workers = check_workers(workers)
    items = list(subjects)
    if workers == 1 or len(items) <= 1:
        return [work(item) for item in items]
    # even load at the end without a task (and a pickle) per subject (the module notes)
    size = max(1, math.ceil(len(items) / (CHUNKS_PER_WORKER * workers)))
    chunks = [items[i:i + size] for i in range(0, len(items), size)]
    context = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(max_workers=min(workers, len(chunks)), mp_context=context) as pool:
        futures = [pool.submit(_run_chunk, work, chunk) for chunk in chunks]
        return [result for future in futures for result in future.result()]
