"""Who may read what in the PostgreSQL registry: a clinic role that sees names, a research
role that sees pseudonymous codes and data only, both enforced by the server (issue 32,
"Roles").

Why by the server: under the GDPR pseudonymised data remain personal data and the key
(names ↔ codes) is kept apart. A researcher's login must not be able to read a name by any
query, raw SQL included, so the separation cannot live in the console's code.

How:

* `clinic` (a group role; each therapist's or station's login is a member) reads and
  writes the registry's tables: SELECT, INSERT and UPDATE, DELETE only of what a trial
  withdrawn at Start takes with it (`WITHDRAWN_WITH_A_TRIAL`; numbering.py keeps it the
  last one), INSERT without UPDATE on the append-only tables (their triggers refuse it too).
* `research` (a group role; each researcher's login is a member) has no privilege on any
  table but SELECT on the columns of `VISIBLE_TO_RESEARCH` (column privileges), and the
  same columns as views in the schema `research` (`SELECT * FROM research.patients` works;
  `SELECT first_name FROM patients` is refused: "permission denied for table patients").
  An export made through this role can only hold what these columns hold.
* Hidden from research (data minimisation: researchers get codes and data only): every
  person's name, the patient's and the staff's (therapist, rater, author, who marked a
  trial or corrected a record); every free text a person typed, which may name someone (a
  patient's and a session's notes, a note's text, a session's location, the reasons given
  for a mark or a correction, a plan's and its blocks' names: research's view shows the
  plan without them); corrections of a name (the view leaves out those rows, whose old
  and new values are names); and every seal, which digests the hidden values with the
  visible ones and would let a dictionary of names be tried against it. Kept: the words
  the console itself wrote (why a trial or a plan run ended: a fault's message).
* What the server shows of the tables elsewhere follows the same privileges: the planner's
  statistics (`pg_stats`, whose most common values of a column would list names) show
  research only the columns it may read.
* Nobody else: the database's CONNECT and the public schema's USAGE are taken from PUBLIC
  and given to the two roles (and the owner, who creates and migrates the schema).
"""

from __future__ import annotations

from dataclasses import dataclass

from app.records.registry.postgres.tables import REGISTRY_TABLES, metadata

HIDDEN_FROM_RESEARCH: dict[str, tuple[str, ...]] = {
    "patients": ("first_name", "last_name", "notes"),
    "sessions": ("therapist", "notes", "location"),
    "plans": ("name",),
    "scales": ("rater",),
    "notes": ("text", "author"),
    "trial_marks": ("reason", "marked_by"),
    "corrections": ("reason", "corrected_by"),
}
"""Columns research never reads (besides every `seal`): names and typed free text."""

_PLAN_WITHOUT_NAMES = (
    "((plan::jsonb - 'name') || jsonb_build_object('blocks', coalesce((SELECT jsonb_agg("
    "b - 'name' ORDER BY i) FROM jsonb_array_elements(plan::jsonb -> 'blocks') WITH "
    "ORDINALITY AS e(b, i)), '[]'::jsonb)))::text")

DERIVED_FOR_RESEARCH: dict[str, dict[str, str]] = {"plans": {"plan": _PLAN_WITHOUT_NAMES}}
"""Columns research reads through its view only, as these expressions make them: a plan
without the names typed into it (its own and its blocks'), as JSON text (jsonb's form:
keys sorted by length, `": "` spacing; the same values)."""

NAME_FIELDS = ("first_name", "last_name")
"""The patient's fields whose corrections are left out of research's corrections view."""

ROW_FILTERED = {"corrections": f"field NOT IN ({', '.join(repr(f) for f in NAME_FIELDS)})"}
"""Tables research reads through its view only, without the rows these conditions leave
out (no column privilege can leave out a row)."""

APPEND_ONLY_TABLES = ("scales", "notes", "trial_marks", "corrections")
WITHDRAWN_WITH_A_TRIAL = ("trials", "plan_steps", "proposals")
"""The tables clinic may delete from: a trial withdrawn at Start (its file never written,
Registry.withdraw_trial; numbering.py keeps it the last one) takes its plan step and its
proposals with it."""


def visible_to_research(table: str) -> tuple[str, ...]:
    """The columns of `table` whose values research reads (through its view, or in the
    table itself), in the table's order."""
    hidden = {*HIDDEN_FROM_RESEARCH.get(table, ()), "seal"}
    return tuple(c.name for c in metadata.tables[table].columns if c.name not in hidden)


def granted_to_research(table: str) -> tuple[str, ...]:
    """The columns of `table` itself research may read: those of its view but the derived
    ones; none of a table whose view leaves out rows."""
    if table in ROW_FILTERED:
        return ()
    derived = DERIVED_FOR_RESEARCH.get(table, {})
    return tuple(c for c in visible_to_research(table) if c not in derived)


@dataclass(frozen=True)
class Roles:
    """The names of the two group roles. Roles are the server's, shared by its databases:
    a server with several registries (a training copy, a second site) names theirs apart."""

    clinic: str = "rehab_clinic"
    research: str = "rehab_research"

    def statements(self) -> tuple[str, ...]:
        """The roles (made when missing), their privileges and research's views, in the
        registry's database after its tables are created."""
        return (*self._roles(), *self._database(), *self._clinic(), *self._research())

    def _roles(self) -> tuple[str, ...]:
        # CREATE ROLE has no IF NOT EXISTS; two registries made at once both may try
        return tuple(
            f"""DO $$ BEGIN
                    CREATE ROLE {role} NOLOGIN;
                EXCEPTION WHEN duplicate_object OR unique_violation THEN NULL;
                END $$"""
            for role in (self.clinic, self.research))

    def _database(self) -> tuple[str, ...]:
        both = f"{self.clinic}, {self.research}"
        return (
            f"""DO $$ BEGIN
                    EXECUTE format('REVOKE ALL ON DATABASE %I FROM PUBLIC',
                                   current_database());
                    EXECUTE format('GRANT CONNECT ON DATABASE %I TO {both}',
                                   current_database());
                END $$""",
            "REVOKE ALL ON SCHEMA public FROM PUBLIC",
            f"GRANT USAGE ON SCHEMA public TO {both}",
            "CREATE SCHEMA research",
            f"GRANT USAGE ON SCHEMA research TO {self.research}",
            f"GRANT SELECT ON schema_version TO {both}",
        )

    def _clinic(self) -> tuple[str, ...]:
        out = []
        for table in REGISTRY_TABLES:
            if table in APPEND_ONLY_TABLES:
                privileges = "SELECT, INSERT"
            elif table in WITHDRAWN_WITH_A_TRIAL:
                privileges = "SELECT, INSERT, UPDATE, DELETE"
            else:
                privileges = "SELECT, INSERT, UPDATE"
            out.append(f"GRANT {privileges} ON {table} TO {self.clinic}")
        out.append(f"GRANT USAGE ON ALL SEQUENCES IN SCHEMA public TO {self.clinic}")
        return tuple(out)

    def _research(self) -> tuple[str, ...]:
        out = []
        for table in REGISTRY_TABLES:
            if granted := granted_to_research(table):
                out.append(f"GRANT SELECT ({', '.join(granted)}) ON {table} "
                           f"TO {self.research}")
            out.append(research_view(table))
            out.append(f"GRANT SELECT ON research.{table} TO {self.research}")
        return tuple(out)


WITHHELD = "withheld from research"
"""What research's views show for a reason typed by staff (a trial marked invalid, a
record corrected): not empty, which the console reads as "no reason, valid"."""
_WITHHELD_COLUMNS = {("trial_marks", "reason"), ("corrections", "reason")}


ADDED_AT: dict[tuple[str, str], int] = {("trials", "stored_in"): 11,
                                        ("proposals", "patient_id"): 13}
"""Columns a schema after v10 added (table, column) -> version: a view made by an earlier
step of the server's migrations leaves them out (they do not exist yet)."""


def research_columns(table: str, at: int | None = None) -> tuple[str, ...]:
    """The columns of research's view of `table`: the table's, in its order, but its seal
    (schema v10). The hidden ones are there, as empty text (a reason: `WITHHELD`), so the
    registry's own reads run unchanged on a researcher's login (Registry on `search_path`
    research: names and typed text come back ''), and no name can be read through them.
    `at`: as at that schema version (today's by default)."""
    return tuple(c.name for c in metadata.tables[table].columns if c.name != "seal"
                 and (at is None or ADDED_AT.get((table, c.name), 0) <= at))


def research_view(table: str, at: int | None = None) -> str:
    """Research's view of `table` (as at schema `at`, today's by default)."""
    derived = DERIVED_FOR_RESEARCH.get(table, {})
    hidden = HIDDEN_FROM_RESEARCH.get(table, ())
    columns = ", ".join(f"{derived[c]} AS {c}" if c in derived
                        else f"'{WITHHELD}'::text AS {c}" if (table, c) in _WITHHELD_COLUMNS
                        else f"''::text AS {c}" if c in hidden else c
                        for c in research_columns(table, at))
    where = ROW_FILTERED.get(table)
    return (f"CREATE VIEW research.{table} WITH (security_barrier) AS SELECT {columns} "
            f"FROM public.{table}" + (f" WHERE {where}" if where else ""))
