"""The registry's tables at today's schema (`SCHEMA_VERSION`, app.records.registry.schema) as
SQLAlchemy 2 Core metadata, which creates them on PostgreSQL.

Why a second description of the same tables: the SQLite registry is built by replaying its
historic DDL (schema.MIGRATIONS, as each version shipped), which only SQLite reads. A server
needs the schema as it is today, in types the server keeps exactly what SQLite keeps, and the
rest of the registry's code needs tables it can build its queries from on both engines
(docs/stations.md). tests/app/records/postgres/test_tables.py holds these tables to the
SQLite registry's: the same tables, the same columns in the same order, the same NULLs and
defaults, and the same sealed columns (seals.SEALED).

The types are chosen so a row reads back, and is sealed, as SQLite keeps it:

* SQLite's INTEGER is 64-bit: `BigInteger` everywhere (an int4 would also make the seal's
  function overloads ambiguous, and PostgreSQL would prefer the float one).
* SQLite's REAL is an 8-byte float: `Double` (PostgreSQL's REAL is 4 bytes). A number
  column refuses NaN (SQLite stores NaN as NULL; refusing it says so instead of changing it).
* Times stay UTC ISO text and parameters, metrics and plans JSON text, as on SQLite: the
  seal covers the text as written, and the registry's code reads one form on both engines.
* Ids are identity columns that also accept a given id (`BY DEFAULT`), so a migration from
  a SQLite registry keeps every row's id (and then moves the sequence past them).
"""

from __future__ import annotations

from sqlalchemy import (
    BigInteger,
    CheckConstraint,
    Column,
    Double,
    ForeignKey,
    Identity,
    Index,
    MetaData,
    PrimaryKeyConstraint,
    SmallInteger,
    Table,
    Text,
    UniqueConstraint,
    text,
)

SCHEMA_VERSION = 13
"""The SQLite registry's schema version these tables are (schema.SCHEMA_VERSION)."""

metadata = MetaData()


def _id() -> Column:
    return Column("id", BigInteger, Identity(), primary_key=True)


def _ref(name: str, target: str, *, nullable: bool = False) -> Column:
    return Column(name, BigInteger, ForeignKey(target, ondelete="RESTRICT"), nullable=nullable)


def _text(name: str, *, nullable: bool = True, default: str | None = None) -> Column:
    server_default = None if default is None else text(f"'{default}'")
    return Column(name, Text, nullable=nullable, server_default=server_default)


def _real(name: str, *, nullable: bool = True) -> Column:
    return Column(name, Double, CheckConstraint(f"{name} <> 'NaN'::float8",
                                                name=f"{name}_is_a_number"),
                  nullable=nullable)


def _seal() -> Column:
    return Column("seal", Text)


patients = Table(
    "patients", metadata,
    _id(),
    Column("code", Text, nullable=False, unique=True),
    _text("first_name"),
    _text("last_name"),
    Column("birth_year", BigInteger),
    _text("side"),
    _real("body_mass_kg"),
    _real("upper_arm_m"),
    _real("forearm_m"),
    _real("shoulder_x_m"),
    _real("shoulder_y_m"),
    _text("notes", nullable=False, default=""),
    _text("created_at", nullable=False),
    _seal(),
    _text("sex"),
    _text("handedness"),
    CheckConstraint("side IS NULL OR side IN ('right', 'left')", name="patients_side"),
    CheckConstraint("sex IS NULL OR sex IN ('female', 'male')", name="patients_sex"),
    CheckConstraint("handedness IS NULL OR handedness IN ('right', 'left')",
                    name="patients_handedness"),
)

sessions = Table(
    "sessions", metadata,
    _id(),
    _ref("patient_id", "patients.id"),
    Column("number", BigInteger, nullable=False),
    _text("date", nullable=False),
    _text("therapist", nullable=False, default=""),
    _text("notes", nullable=False, default=""),
    _text("location", nullable=False, default=""),
    _seal(),
    CheckConstraint("number >= 1", name="sessions_number"),
    UniqueConstraint("patient_id", "number", name="sessions_patient_number"),
)

TRIAL_STATUSES = ("recording", "complete", "stopped_early", "faulted", "recording_lost")

trials = Table(
    "trials", metadata,
    _id(),
    _ref("session_id", "sessions.id"),
    Column("number", BigInteger, nullable=False),
    _text("parameters", nullable=False),
    Column("file", Text, nullable=False, unique=True),
    _text("metrics", nullable=False, default="{}"),
    _text("status", nullable=False),
    _text("started_at", nullable=False),
    _text("ended_at"),
    _text("patient_kind"),
    _text("backend"),
    _text("end_reason", nullable=False, default=""),
    _text("assistance"),
    _seal(),
    _text("station"),
    _text("checksum"),
    _text("stored_in"),
    CheckConstraint("number >= 1", name="trials_number"),
    CheckConstraint("checksum IS NULL OR checksum ~ '^[0-9a-f]{64}$'", name="trials_checksum"),
    CheckConstraint(f"status IN ({', '.join(repr(s) for s in TRIAL_STATUSES)})",
                    name="trials_status"),
    UniqueConstraint("session_id", "number", name="trials_session_number"),
)

proposals = Table(
    "proposals", metadata,
    Column("trial_id", BigInteger, ForeignKey("trials.id", ondelete="RESTRICT"),
           primary_key=True, autoincrement=False),
    _text("proposal", nullable=False),
    _text("decision", nullable=False, default="pending"),
    _ref("next_trial_id", "trials.id", nullable=True),
    _text("proposed_at", nullable=False),
    _text("decided_at"),
    _seal(),
    # schema v13: the patient of the proposal's trial, kept so by the server (postgres.
    # PROPOSALS_PATIENT), which finds the patient's pending proposal by it
    _ref("patient_id", "patients.id", nullable=True),
    CheckConstraint("decision IN ('pending', 'accepted', 'changed', 'kept')",
                    name="proposals_decision"),
    # the pending ones by patient (schema v13, app.records.registry.proposals.
    # PENDING_BY_PATIENT), and those decided by a trial (v12), without reading every proposal
    Index("proposals_pending_by_patient", "patient_id", "trial_id",
          postgresql_where=text("decision = 'pending'")),
    Index("proposals_by_next_trial", "next_trial_id"),
)

plans = Table(
    "plans", metadata,
    _id(),
    _ref("patient_id", "patients.id"),
    _text("name", nullable=False),
    _text("plan", nullable=False),
    _text("template", nullable=False, default=""),
    _ref("based_on", "plans.id", nullable=True),
    _text("created_at", nullable=False),
    _seal(),
)

plan_runs = Table(
    "plan_runs", metadata,
    _id(),
    _ref("plan_id", "plans.id"),
    _text("started_at", nullable=False),
    _text("ended_at"),
    _text("status", nullable=False),
    _text("end_reason", nullable=False, default=""),
    _seal(),
    _text("station"),
    CheckConstraint("status IN ('running', 'complete', 'stopped', 'emergency_stop', "
                    "'faulted', 'interrupted')", name="plan_runs_status"),
)

plan_steps = Table(
    "plan_steps", metadata,
    _ref("run_id", "plan_runs.id"),
    Column("step", BigInteger, nullable=False),
    Column("block", BigInteger, nullable=False),
    Column("round", BigInteger, nullable=False),
    _text("kind", nullable=False),
    Column("trial_id", BigInteger, ForeignKey("trials.id", ondelete="RESTRICT"), unique=True),
    _real("planned_s", nullable=False),
    _real("taken_s"),
    _seal(),
    PrimaryKeyConstraint("run_id", "step", name="plan_steps_pkey"),
    CheckConstraint("step >= 1", name="plan_steps_step"),
    CheckConstraint("block >= 1", name="plan_steps_block"),
    CheckConstraint("round >= 1", name="plan_steps_round"),
    CheckConstraint("kind IN ('trial', 'rest')", name="plan_steps_kind"),
    CheckConstraint("(kind = 'trial') = (trial_id IS NOT NULL)", name="plan_steps_trial"),
)

SCALES = ("fugl_meyer", "arat", "ashworth", "pain", "fatigue")

scales = Table(
    "scales", metadata,
    _id(),
    _ref("session_id", "sessions.id"),
    _text("scale", nullable=False),
    Column("total", BigInteger),
    _text("detail", nullable=False, default="{}"),
    _text("rater", nullable=False),
    _text("recorded_at", nullable=False),
    _seal(),
    CheckConstraint(f"scale IN ({', '.join(repr(s) for s in SCALES)})", name="scales_scale"),
    CheckConstraint("(total IS NULL) = (scale = 'ashworth')", name="scales_total"),
    CheckConstraint("length(rater) > 0", name="scales_rater"),
    Index("scales_by_session", "session_id"),
)

notes = Table(
    "notes", metadata,
    _id(),
    _ref("session_id", "sessions.id"),
    _ref("trial_id", "trials.id", nullable=True),
    _text("text", nullable=False),
    _text("author", nullable=False),
    _text("written_at", nullable=False),
    _seal(),
    CheckConstraint("length(text) > 0", name="notes_text"),
    CheckConstraint("length(author) > 0", name="notes_author"),
    Index("notes_by_session", "session_id"),
)

trial_marks = Table(
    "trial_marks", metadata,
    _id(),
    _ref("trial_id", "trials.id"),
    Column("valid", BigInteger, nullable=False),
    _text("reason", nullable=False),
    _text("marked_by", nullable=False),
    _text("marked_at", nullable=False),
    _seal(),
    CheckConstraint("valid IN (0, 1)", name="trial_marks_valid"),
    CheckConstraint("length(reason) > 0", name="trial_marks_reason"),
    CheckConstraint("length(marked_by) > 0", name="trial_marks_marked_by"),
    Index("trial_marks_by_trial", "trial_id"),
)

corrections = Table(
    "corrections", metadata,
    _id(),
    _ref("patient_id", "patients.id"),
    _text("field", nullable=False),
    _text("old_value", nullable=False),
    _text("new_value", nullable=False),
    _text("reason", nullable=False),
    _text("corrected_by", nullable=False),
    _text("corrected_at", nullable=False),
    _seal(),
    CheckConstraint("length(reason) > 0", name="corrections_reason"),
    CheckConstraint("length(corrected_by) > 0", name="corrections_corrected_by"),
    Index("corrections_by_patient", "patient_id"),
)

schema_version = Table(
    "schema_version", metadata,
    Column("one", SmallInteger, primary_key=True, autoincrement=False,
           server_default=text("1")),
    Column("version", BigInteger, nullable=False),
    CheckConstraint("one = 1", name="schema_version_one_row"),
)
"""PostgreSQL's `PRAGMA user_version`: one row, the schema version of the registry."""

REGISTRY_TABLES = ("patients", "sessions", "trials", "proposals", "plans", "plan_runs",
                   "plan_steps", "scales", "notes", "trial_marks", "corrections")
"""The registry's own tables, in the SQLite registry's order (schema_version aside)."""
