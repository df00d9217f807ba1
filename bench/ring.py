"""Cost of the shared-memory record ring: the loop's per-tick push and the readers' drain.

Run: .venv/bin/python bench/ring.py [--pushes N] [--records N]
Prints push cost p50 / p99 / max in µs for one full record (device.recording.record.RECORD_DTYPE)
written the ways the loop can write it, then drain throughput in records/s and MB/s:
copying out of a filled ring in batches (one process), and end to end with the writer
in its own process pushing flat out while this process drains as the recorder.
"""

from __future__ import annotations

import argparse
import gc
import multiprocessing as mp
import time

import numpy as np

from device.recording.record import RECORD_DTYPE
from device.recording.ring import RecordRing, flat_names

CAPACITY = 8192


def plain_values(seq: int, dtype: np.dtype = RECORD_DTYPE) -> tuple:
    """One record as the loop has it: plain Python ints and floats in flat_names order."""
    values = []
    for name in dtype.names:
        field = dtype.fields[name][0]
        count = int(np.prod(field.shape)) if field.shape else 1
        integer = field.base.kind in "iub"
        values.extend(seq % 200 if integer else seq * 0.001 + k for k in range(count))
    return tuple(values)


def nested_values(flat: tuple, dtype: np.dtype = RECORD_DTYPE) -> tuple:
    """The same record nested the numpy way (a tuple per sub-array field)."""
    out, i = [], 0
    for name in dtype.names:
        shape = dtype.fields[name][0].shape
        count = int(np.prod(shape)) if shape else 1
        out.append(flat[i] if not shape else tuple(flat[i:i + count]))
        i += count
    return tuple(out)


def percentiles(samples_ns: list[int]) -> tuple[float, float, float]:
    a = np.asarray(samples_ns, dtype=float) / 1000.0
    return float(np.percentile(a, 50)), float(np.percentile(a, 99)), float(a.max())


def measure(ring: RecordRing, write, n: int) -> tuple[float, float, float]:
    """Times `write(seq)`; the recorder's commit runs between samples, outside the timing."""
    clock = time.perf_counter_ns
    out = []
    for seq in range(n):
        if seq % (CAPACITY // 2) == 0:
            ring.commit_read(ring.write_count)
        t0 = clock()
        write(seq)
        out.append(clock() - t0)
    return percentiles(out)


def push_costs(n: int) -> None:
    flat = plain_values(1)
    nested = nested_values(flat)
    fields = [(name, nested[i]) for i, name in enumerate(RECORD_DTYPE.names)]
    scratch = np.zeros(1, RECORD_DTYPE)

    with RecordRing.create(CAPACITY) as ring:
        def push(seq):
            ring.push(flat)

        def slot_all_fields(seq):
            record = ring.slot()
            for name, value in fields:
                record[name] = value
            ring.commit()

        def slot_three_fields(seq):
            record = ring.slot()
            record["tick"] = seq
            record["time"] = 0.002
            record["robot_angle"] = (0.1, 0.2)
            ring.commit()

        def slot_commit_only(seq):
            ring.slot()
            ring.commit()

        def numpy_tuple(seq):
            # Reference, not ring API: numpy's own tuple-to-record assignment.
            scratch[0] = nested

        def check(seq):
            ring.would_overwrite_unrecorded()

        cases = [
            (f"push(tuple of {len(flat)} plain numbers)", push),
            ("slot() + 31 field writes + commit()", slot_all_fields),
            ("slot() + 3 field writes + commit()", slot_three_fields),
            ("slot() + commit() alone", slot_commit_only),
            ("would_overwrite_unrecorded()", check),
            ("(ref) numpy record = nested tuple", numpy_tuple),
        ]
        print(f"push cost, {RECORD_DTYPE.itemsize}-byte record, {n} calls each, gc off")
        print(f"{'call':<40}{'p50 µs':>9}{'p99 µs':>9}{'max µs':>9}")
        gc.disable()
        try:
            for name, write in cases:
                measure(ring, write, 2000)  # warm up
                p50, p99, worst = measure(ring, write, n)
                print(f"{name:<40}{p50:9.2f}{p99:9.2f}{worst:9.1f}")
        finally:
            gc.enable()


def drain_copy(records: int) -> None:
    print(f"\ndrain, one process: read_new() from a full ring of {CAPACITY}, "
          f"{records} records per batch size")
    print(f"{'batch':>8}{'records/s':>14}{'MB/s':>9}{'µs/batch':>10}")
    size = RECORD_DTYPE.itemsize
    with RecordRing.create(CAPACITY, recorded=False) as ring:
        flat = plain_values(1)
        for _ in range(CAPACITY + 7):  # wrapped, so batches cross the end of the ring
            ring.push(flat)
        start = ring.write_count - CAPACITY
        for batch in (1, 16, 256, 4096):
            calls = max(1, records // batch)
            t0 = time.perf_counter()
            for i in range(calls):
                ring.read_new(start + (i * batch) % (CAPACITY - batch), max_n=batch)
            dt = time.perf_counter() - t0
            rate = calls * batch / dt
            print(f"{batch:8d}{rate:14,.0f}{rate * size / 1e6:9.0f}{dt / calls * 1e6:10.1f}")


def _writer(name: str, n: int) -> None:
    ring = RecordRing.attach(name)
    try:
        flat = plain_values(1)
        for _ in range(n):
            while ring.would_overwrite_unrecorded():
                time.sleep(0)
            ring.push(flat)
        ring.finish()
    finally:
        ring.close()


def drain_end_to_end(n: int) -> None:
    ctx = mp.get_context("spawn")
    size = RECORD_DTYPE.itemsize
    print(f"\ndrain, writer in another process pushing {n} records flat out, "
          f"this process recording (read_new + commit_read), ring of {CAPACITY}")
    with RecordRing.create(CAPACITY) as ring:
        writer = ctx.Process(target=_writer, args=(ring.name, n))
        writer.start()
        while ring.write_count == 0 and writer.is_alive():
            time.sleep(0.001)
        t0 = time.perf_counter()
        cursor = batches = 0
        while not ring.drained(cursor):
            batch = ring.read_new(cursor)
            if batch.lost:
                raise RuntimeError(f"recorder lost {batch.lost} records")
            cursor = batch.cursor
            ring.commit_read(cursor)
            batches += 1
            if len(batch.records) == 0:
                time.sleep(0.0002)
        dt = time.perf_counter() - t0
        writer.join()
    rate = n / dt
    print(f"{rate:,.0f} records/s, {rate * size / 1e6:.0f} MB/s, {batches} reads; "
          f"the 2 ms loop needs 500 records/s ({500 * size / 1e3:.0f} kB/s)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--pushes", type=int, default=100_000)
    parser.add_argument("--records", type=int, default=400_000)
    args = parser.parse_args()
    print(f"flat push order: {', '.join(flat_names()[:4])}, … ({len(flat_names())} numbers)\n")
    push_costs(args.pushes)
    drain_copy(args.records)
    drain_end_to_end(args.records)


if __name__ == "__main__":
    main()
