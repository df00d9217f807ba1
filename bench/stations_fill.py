"""bench/stations.py's registry and its fill: the throwaway server's registry made as a
department's owner makes one, a course of synthetic patients (parameters made harder over
the course, metrics as bench/registry.py makes them, a proposal after each trial), and
the fill by COPY through the server's numbering and seal triggers. Imported by
bench/stations.py, which puts the repository on the path first.
"""

from __future__ import annotations

import dataclasses
import datetime
import json
import math
import multiprocessing as mp
import secrets
import sys
import time
from pathlib import Path

import numpy as np
import sqlalchemy as sa

from app.records.datadir import DataDir
from app.records.registry import Registry
from app.records.registry.postgres import Roles, create_registry
from app.records.registry.values import utc_text
from app.trials.progression import Proposal
from core.metrics import TrialMetrics
from core.trial import TrialParameters

TRIALS_PER_SESSION = 20
METRIC_NAMES = tuple(f.name for f in dataclasses.fields(TrialMetrics)
                     if f.type in ("float", "int"))
COURSE_START = datetime.datetime(2024, 1, 8, 9, 0, tzinfo=datetime.UTC)


def parameters_for(session: int, n_sessions: int) -> TrialParameters:
    # as bench/registry.py: a bigger D, less time per lap, less assistance over the course
    stage = min(3, 4 * session // max(n_sessions, 1))
    return TrialParameters(radius_m=0.08 + 0.02 * stage, duration_s=6.0 - stage,
                           assistance_level=1.0 - 0.15 * stage)


def metrics_rows(rng: np.random.Generator, progress: np.ndarray) -> list[str]:
    """The metrics JSON of len(progress) trials, as Registry.finish_trial stores
    bench/registry.py's metrics_for (values.metrics_json: floats, NaN as null), made a
    patient's history at a time."""
    n = len(progress)
    values = {name: rng.lognormal(0.0, 0.3, n) for name in METRIC_NAMES}
    skill = 1.0 - 0.6 * progress
    values.update(
        rmse_x_m=0.02 * skill * rng.lognormal(0.0, 0.2, n),
        rmse_y_m=0.025 * skill * rng.lognormal(0.0, 0.2, n),
        directional_performance_pct=100.0 * np.minimum(
            1.0, 0.5 + 0.4 * progress + 0.05 * rng.standard_normal(n)),
        sparc=-2.5 * skill + 0.1 * rng.standard_normal(n),
        ldlj=-8.0 * skill + 0.3 * rng.standard_normal(n),
        path_length_ratio=1.0 + 0.4 * skill * rng.lognormal(0.0, 0.2, n),
        n_reaches=np.zeros(n),
    )
    names = [name for name in values if name != "reaction_time_s"]
    columns = [values[name].tolist() for name in names]
    tail = ', "reaction_time_s": null' if "reaction_time_s" in values else ""
    out = []
    for row in zip(*columns, strict=True):
        body = json.dumps(dict(zip(names, row, strict=True)))
        out.append(body[:-1] + tail + "}")
    return out


def proposal_for(parameters: TrialParameters, i: int) -> dict:
    """A proposal as app.trials.finalize records one after each exercise trial."""
    level = max(0.0, parameters.assistance_level - 0.05 * (i % 3))
    return Proposal(level, parameters.duration_s, parameters.tolerance_rad,
                    "assistance" if i % 3 else "none",
                    "the patient tracked well: less assistance" if i % 3 else
                    "keep going: the same again", 0.05, 0.0).to_dict()


def single_metrics(rng: np.random.Generator) -> dict[str, float]:
    return json.loads(metrics_rows(rng, np.array([1.0]))[0].replace("null", "NaN"))


# -- the server and the registry ------------------------------------------------------------


@dataclasses.dataclass
class Bench:
    server: object
    database: str
    owner_url: str
    clinic_url: str


def make_registry(server) -> Bench:
    database = server.create_database("bench_stations")
    tag = secrets.token_hex(3)
    roles = Roles(clinic=f"clinic_{tag}", research=f"research_{tag}")
    owner_url = server.url(database=database)
    engine = sa.create_engine(owner_url, poolclass=sa.NullPool)
    try:
        with engine.begin() as conn:
            create_registry(conn, roles)
    finally:
        engine.dispose()
    server.forget_role(roles.clinic)
    server.forget_role(roles.research)
    user, password = server.create_login("station", roles.clinic)
    return Bench(server, database, owner_url, server.url(user, password, database=database))


# -- 1. the fill ---------------------------------------------------------------------------


def fill_patients(registry: Registry, n: int) -> list[str]:
    return [registry.create_patient("Bench", f"Patient {i:04d}", side="right",
                                    body_mass_kg=80.0, birth_year=1950 + i % 40).code
            for i in range(n)]


def fill_worker(url: str, codes: list[str], trials_per_patient: int, seed: int,
                proposals: bool) -> int:
    """COPY the sessions, then the trials, of the patients `codes` (one transaction per
    patient group), through the server's triggers; with `proposals`, a proposal after each
    trial as the console records them (each decided by the next trial, the last pending).
    Returns the trials written."""
    rng = np.random.default_rng(seed)
    data_dir = DataDir(Path("/nonexistent"))  # trial_file only builds the relative path
    n_sessions = max(1, math.ceil(trials_per_patient / TRIALS_PER_SESSION))
    built = [parameters_for(s, n_sessions) for s in range(n_sessions)]
    parameters = [json.dumps(p.to_dict()) for p in built]
    proposed = [[json.dumps(proposal_for(p, i), allow_nan=False, sort_keys=True)
                 for i in range(3)] for p in built]
    progress = np.arange(trials_per_patient) / trials_per_patient
    engine = sa.create_engine(url, poolclass=sa.NullPool)
    written = 0
    try:
        for start in range(0, len(codes), 20):
            group = codes[start:start + 20]
            with engine.begin() as conn:
                cursor = conn.connection.driver_connection.cursor()
                ids = dict(conn.execute(sa.text("SELECT code, id FROM patients WHERE code = "
                                                "ANY(:codes)"), {"codes": group}).all())
                with cursor.copy("COPY sessions (patient_id, number, date, therapist, "
                                 "location, notes) FROM STDIN") as copy:
                    for code in group:
                        for s in range(n_sessions):
                            day = (COURSE_START + datetime.timedelta(days=2 * s)).date()
                            copy.write_row((ids[code], s + 1, day.isoformat(), "Bench",
                                            "Gym", ""))
                session_ids = {(patient, number): sid for sid, patient, number in conn.execute(
                    sa.text("SELECT s.id, s.patient_id, s.number FROM sessions s "
                            "WHERE s.patient_id = ANY(:ids)"), {"ids": list(ids.values())})}
                with cursor.copy("COPY trials (session_id, number, parameters, file, "
                                 "metrics, status, started_at, ended_at, patient_kind, "
                                 "backend) FROM STDIN") as copy:
                    for code in group:
                        metrics = metrics_rows(rng, progress)
                        for i in range(trials_per_patient):
                            s, t = divmod(i, TRIALS_PER_SESSION)
                            began = COURSE_START + datetime.timedelta(days=2 * s,
                                                                      minutes=3 * t)
                            copy.write_row((
                                session_ids[(ids[code], s + 1)], t + 1, parameters[s],
                                data_dir.trial_file(code, s + 1, t + 1, began), metrics[i],
                                "complete", utc_text(began),
                                utc_text(began + datetime.timedelta(seconds=40)), "weak",
                                "simulator"))
                        written += trials_per_patient
                if not proposals:
                    continue
                rows = conn.execute(sa.text(
                    "SELECT t.id, s.patient_id, s.number FROM trials t JOIN sessions s ON "
                    "s.id = t.session_id WHERE s.patient_id = ANY(:ids) "
                    "ORDER BY s.patient_id, s.number, t.number"),
                    {"ids": list(ids.values())}).all()
                with cursor.copy("COPY proposals (trial_id, proposal, decision, "
                                 "next_trial_id, proposed_at, decided_at) FROM STDIN") as copy:
                    for i, (trial, patient, session) in enumerate(rows):
                        after = rows[i + 1] if i + 1 < len(rows) else None
                        moment = utc_text(COURSE_START + datetime.timedelta(days=2 * session))
                        text = proposed[session - 1][i % 3]
                        if after is not None and after[1] == patient:
                            copy.write_row((trial, text, "accepted", after[0], moment, moment))
                        else:
                            copy.write_row((trial, text, "pending", None, moment, None))
    finally:
        engine.dispose()
    return written


def fill(bench: Bench, data_root: Path, patients: int, trials_per_patient: int,
         workers: int, proposals: bool, shares=None) -> tuple[list[str], dict[str, float]]:
    """`shares(codes)`: the patients' shares, each with what to do before it is filled
    (`[(codes, prepare), …]`, prepare a callable or None; bench/stations_trees.py); by
    default one share, nothing done before."""
    times: dict[str, float] = {}
    t0 = time.perf_counter()
    registry = Registry(data_root / "filler", server=sa.make_url(bench.clinic_url))
    codes = fill_patients(registry, patients)
    times["patients"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    written = 0
    with mp.get_context("spawn").Pool(workers) as pool:
        for share, prepare in (shares(codes) if shares else [(codes, None)]):
            if prepare is not None:
                prepare()
            chunks = [share[i::workers] for i in range(workers)]
            written += sum(pool.starmap(fill_worker, [
                (bench.clinic_url, chunk, trials_per_patient, 100 + i, proposals)
                for i, chunk in enumerate(chunks)]))
    times["trials"] = time.perf_counter() - t0
    times["rows"] = written
    t0 = time.perf_counter()
    engine = sa.create_engine(bench.owner_url, poolclass=sa.NullPool,
                              isolation_level="AUTOCOMMIT")
    try:
        with engine.connect() as conn:
            conn.execute(sa.text("VACUUM ANALYZE"))
            times["size_mb"] = conn.execute(sa.text(
                "SELECT pg_database_size(current_database())")).scalar_one() / 1e6
    finally:
        engine.dispose()
    times["analyze"] = time.perf_counter() - t0
    return codes, times


def throwaway_server():
    """The tests' throwaway PostgreSQL server (tests/postgres.py: initdb in a temporary
    folder, a free port on 127.0.0.1), or exit 1 with one line saying why it did not start."""
    from tests.postgres import ServerError, start

    try:
        return start()
    except ServerError as exc:
        print(f"error: the throwaway PostgreSQL server did not start: {exc}", file=sys.stderr)
        sys.exit(1)
