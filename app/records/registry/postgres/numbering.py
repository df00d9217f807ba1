"""Session and trial numbers unique and gap-free per patient across stations, enforced by
the PostgreSQL server (issue 32, "Stations").

Why in the server: on SQLite one console writes at a time (BEGIN IMMEDIATE), so the console
that read the next number is the one that inserts it. Several stations on one server
write at once; each station's own check would race with the others'. So the server holds
the rule:

* Registering a session or a trial first locks its patient's row (`FOR NO KEY UPDATE`), so
  registrations for one patient take turns while other patients' go on; then the number
  must be the one after the highest the patient has (sessions) or the session has (trials).
  A row inserted without a number (NULL) gets that number from the server, which is what a
  station should do: `INSERT … RETURNING number` never fails for a number another station
  took. A given number that is not the next is refused, naming the next.
* `FOR NO KEY UPDATE`, not `FOR UPDATE`: the foreign-key checks of every insert that names
  the patient (a plan, a correction) take `FOR KEY SHARE` on the patient's row; `FOR UPDATE`
  would wait for them and could deadlock with a station that wrote one of those first.
  `FOR NO KEY UPDATE` waits only for another numbering (or an edit of the patient's row).
* Under READ COMMITTED (the default) each statement of the trigger sees what was committed
  before it, so after the lock it sees the number the station before it took. Under
  REPEATABLE READ it would not, and the UNIQUE constraints (tables.py) would refuse the
  duplicate instead: the numbers stay unique either way.
* A number, and the patient or session it belongs to, never change once given; a trial
  may be taken back (`withdraw_trial`, whose file was never written) only while it is the
  last of its session, and a session only while it is the patient's last (and has no
  trials, which the foreign keys already require): no gap is ever left.
"""

from __future__ import annotations

_LOCK_PATIENT = "PERFORM 1 FROM public.patients WHERE id = patient FOR NO KEY UPDATE;"

SESSIONS = (
    f"""CREATE FUNCTION sessions_numbered() RETURNS trigger LANGUAGE plpgsql AS $$
        DECLARE
            patient bigint := NEW.patient_id;
            next_number bigint;
        BEGIN
            {_LOCK_PATIENT}
            SELECT coalesce(max(number), 0) + 1 INTO next_number
                FROM public.sessions WHERE patient_id = patient;
            IF NEW.number IS NULL THEN
                NEW.number := next_number;
            ELSIF NEW.number <> next_number THEN
                RAISE EXCEPTION 'session number % is not the next one of patient %: '
                    'session numbers have no gaps and no repeats; use %',
                    NEW.number, patient, next_number
                    USING ERRCODE = 'integrity_constraint_violation';
            END IF;
            RETURN NEW;
        END $$""",
    """CREATE TRIGGER a_sessions_numbered BEFORE INSERT ON sessions
        FOR EACH ROW EXECUTE FUNCTION sessions_numbered()""",
)

TRIALS = (
    f"""CREATE FUNCTION trials_numbered() RETURNS trigger LANGUAGE plpgsql AS $$
        DECLARE
            patient bigint;
            next_number bigint;
        BEGIN
            SELECT patient_id INTO patient FROM public.sessions WHERE id = NEW.session_id;
            {_LOCK_PATIENT}
            SELECT coalesce(max(number), 0) + 1 INTO next_number
                FROM public.trials WHERE session_id = NEW.session_id;
            IF NEW.number IS NULL THEN
                NEW.number := next_number;
            ELSIF NEW.number <> next_number THEN
                RAISE EXCEPTION 'trial number % is not the next one of session %: '
                    'trial numbers have no gaps and no repeats; use %',
                    NEW.number, NEW.session_id, next_number
                    USING ERRCODE = 'integrity_constraint_violation';
            END IF;
            RETURN NEW;
        END $$""",
    """CREATE TRIGGER a_trials_numbered BEFORE INSERT ON trials
        FOR EACH ROW EXECUTE FUNCTION trials_numbered()""",
)

KEPT = (
    """CREATE FUNCTION numbers_kept() RETURNS trigger LANGUAGE plpgsql AS $$
        BEGIN
            IF NEW.number IS DISTINCT FROM OLD.number
               OR (TG_TABLE_NAME = 'sessions' AND
                   to_jsonb(NEW) -> 'patient_id' IS DISTINCT FROM to_jsonb(OLD) -> 'patient_id')
               OR (TG_TABLE_NAME = 'trials' AND
                   to_jsonb(NEW) -> 'session_id' IS DISTINCT FROM to_jsonb(OLD) -> 'session_id')
            THEN
                RAISE EXCEPTION '% numbers are kept as given: a % keeps its number and '
                    'whose it is', TG_TABLE_NAME, rtrim(TG_TABLE_NAME, 's')
                    USING ERRCODE = 'integrity_constraint_violation';
            END IF;
            RETURN NEW;
        END $$""",
    """CREATE TRIGGER a_sessions_numbers_kept BEFORE UPDATE ON sessions
        FOR EACH ROW EXECUTE FUNCTION numbers_kept()""",
    """CREATE TRIGGER a_trials_numbers_kept BEFORE UPDATE ON trials
        FOR EACH ROW EXECUTE FUNCTION numbers_kept()""",
    """CREATE FUNCTION only_the_last_goes() RETURNS trigger LANGUAGE plpgsql AS $$
        DECLARE
            patient bigint;
            later boolean;
        BEGIN
            IF TG_TABLE_NAME = 'sessions' THEN
                patient := OLD.patient_id;
                {lock}
                SELECT EXISTS (SELECT 1 FROM public.sessions WHERE patient_id = patient
                               AND number > OLD.number) INTO later;
            ELSE
                SELECT s.patient_id INTO patient FROM public.sessions s
                    WHERE s.id = (to_jsonb(OLD) ->> 'session_id')::bigint;
                {lock}
                SELECT EXISTS (SELECT 1 FROM public.trials
                               WHERE session_id = (to_jsonb(OLD) ->> 'session_id')::bigint
                               AND number > OLD.number) INTO later;
            END IF;
            IF later THEN
                RAISE EXCEPTION '% % cannot be taken back: a later one exists, and numbers '
                    'have no gaps', rtrim(TG_TABLE_NAME, 's'), OLD.number
                    USING ERRCODE = 'integrity_constraint_violation';
            END IF;
            RETURN OLD;
        END $$""".replace("{lock}", _LOCK_PATIENT),
    """CREATE TRIGGER a_sessions_only_the_last_goes BEFORE DELETE ON sessions
        FOR EACH ROW EXECUTE FUNCTION only_the_last_goes()""",
    """CREATE TRIGGER a_trials_only_the_last_goes BEFORE DELETE ON trials
        FOR EACH ROW EXECUTE FUNCTION only_the_last_goes()""",
)


def statements() -> tuple[str, ...]:
    """The numbering's functions and triggers, after the tables are created. Their
    triggers' names start with `a_` so they fire before the seal's (`zz_`): the seal covers
    the number the server gave."""
    return (*SESSIONS, *TRIALS, *KEPT)
