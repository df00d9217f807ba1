"""What a therapist records beside the robot, on the command line (schema v8, issue 31):
`rehab scales add|show`, `rehab note`, `rehab notes`, `rehab invalid`, `rehab valid`,
`rehab correct` and `rehab corrections`.

Every entry says who made it (`--by`); the registry adds when. A scale is given as its
total or as `KEY=VALUE` scores (Fugl-Meyer parts A-D or its 33 items, ARAT's subscales,
Ashworth's muscle groups: app.records.scales); anything out of range is refused in one
line, exit 2, and nothing is stored.
"""

from __future__ import annotations

import argparse

from app.cli.common import record_id, registry_for, subcommands
from app.records.registry import CORRECTABLE
from app.records.scales import (
    ARAT,
    ASHWORTH,
    ASHWORTH_GROUPS,
    FUGL_MEYER,
    SCALE_LABELS,
    SCALES,
)
from app.records.typed import typed_scores, typed_value

_BY_HELP = "who records this (the therapist's name)"


def session_number(text: str) -> int:
    """An argparse type for a session's number: a whole number from 1 to 999999."""
    stripped = text.strip()
    if not (stripped.isascii() and stripped.isdigit() and len(stripped) <= 6
            and int(stripped) >= 1):
        raise argparse.ArgumentTypeError(f"{text!r} is not a session number: give a whole "
                                         "number from 1 (`rehab trials CODE` lists them)")
    return int(stripped)


def add_clinical_commands(commands) -> None:
    scales = commands.add_parser(
        "scales", help="a session's clinical scales (Fugl-Meyer, ARAT, Ashworth, pain, "
                       "fatigue)",
        description="Record or show the clinical scales scored in a patient's sessions.")
    sub = subcommands(scales)
    add = sub.add_parser(
        "add", help="record one scale for a session",
        description="Record a scale for a session: its total (fugl_meyer 0-66, arat 0-57, "
                    "pain 0-10, fatigue 0-10), or KEY=VALUE scores: fugl_meyer A= B= C= D= "
                    "(0-36, 0-10, 0-14, 0-6) or its 33 items; arat grasp= grip= pinch= "
                    "gross= (0-18, 0-12, 0-18, 0-9); ashworth GROUP=GRADE (0, 1, 1+, 2, 3, "
                    "4) for any of " + ", ".join(ASHWORTH_GROUPS) + ". Recording a scale "
                    "again for a session supersedes the earlier entry, which is kept.")
    add.add_argument("code", help="the patient's code")
    add.add_argument("session", type=session_number,
                     help="the session's number; the patient's next one opens it (scales "
                          "taken before the session's first trial)")
    add.add_argument("scale", choices=SCALES, help="which scale")
    add.add_argument("scores", nargs="+", metavar="SCORE",
                     help="the total, or KEY=VALUE scores")
    add.add_argument("--by", required=True, help=_BY_HELP)
    add.set_defaults(func=cmd_scales_add)
    show = sub.add_parser("show", help="a patient's scales per session",
                          description="The scales in effect per session (the latest entry "
                                      "of each); --history lists every entry.")
    show.add_argument("code", help="the patient's code")
    show.add_argument("--session", type=session_number, help="one session only")
    show.add_argument("--history", action="store_true",
                      help="every entry, superseded ones too, with who and when")
    show.set_defaults(func=cmd_scales_show)

    note = commands.add_parser("note", help="write a note on a session or a trial",
                               description="Write a note on a patient's session, or on one "
                                           "of its trials (--trial). Notes are kept as "
                                           "written.")
    note.add_argument("code", help="the patient's code")
    note.add_argument("session", type=session_number,
                      help="the session's number; the patient's next one opens it")
    note.add_argument("text", help="the note")
    note.add_argument("--trial", type=record_id, help="the trial's id (`rehab trials CODE`)")
    note.add_argument("--by", required=True, help=_BY_HELP)
    note.set_defaults(func=cmd_note)
    notes = commands.add_parser("notes", help="a patient's notes",
                                description="A patient's notes, oldest first.")
    notes.add_argument("code", help="the patient's code")
    notes.add_argument("--session", type=session_number, help="one session only")
    notes.set_defaults(func=cmd_notes)

    for name, valid in (("invalid", False), ("valid", True)):
        mark = commands.add_parser(
            name, help=("mark a trial invalid (kept, left out of progress, proposals and "
                        "exports)" if not valid else "mark an invalid trial valid again"),
            description=("Mark a trial invalid, saying why: it stays in the registry and its "
                         "file, but Progress, the proposals and study exports leave it out "
                         "unless asked (--include-invalid)." if not valid else
                         "Mark a trial marked invalid valid again, saying why; its marks "
                         "are kept."))
        mark.add_argument("trial_id", type=record_id, help="the trial's id")
        mark.add_argument("--reason", required=True, help="why")
        mark.add_argument("--by", required=True, help=_BY_HELP)
        mark.set_defaults(func=cmd_mark, valid=valid)

    correct = commands.add_parser(
        "correct", help="correct a patient's recorded field (kept in an audit trail)",
        description="Correct one of a patient's fields: " + ", ".join(CORRECTABLE)
                    + ". SI units (kg, m); shoulder_m as x,y (a value starting with '-' after "
                    "'--': rehab correct CODE shoulder_m --reason R --by B -- -0.12,0.73); "
                    "'none' clears a field. The "
                    "old value, the new one, why, who and when are kept.")
    correct.add_argument("code", help="the patient's code")
    correct.add_argument("field", choices=CORRECTABLE, help="the field to correct")
    correct.add_argument("value", help="its new value, in SI units ('none' clears it)")
    correct.add_argument("--reason", required=True, help="why")
    correct.add_argument("--by", required=True, help=_BY_HELP)
    correct.set_defaults(func=cmd_correct)
    corrections = commands.add_parser("corrections", help="a patient's corrections (audit)",
                                      description="Every correction of a patient's fields.")
    corrections.add_argument("code", help="the patient's code")
    corrections.set_defaults(func=cmd_corrections)


# ------------------------------------------------------------------ scales
def cmd_scales_add(args: argparse.Namespace) -> int:
    registry = registry_for(args)
    entry = registry.record_scale(args.code, args.session, args.scale, rater=args.by,
                                  **typed_scores(args.scale, args.scores))
    print(f"{args.code} session {args.session}: {_scale_text(entry)}")
    return 0


def _scale_text(entry) -> str:
    label = SCALE_LABELS[entry.scale]
    if entry.scale == ASHWORTH:
        grades = entry.detail["grades"]
        return f"{label} " + ", ".join(f"{g.replace('_', ' ')} {v}" for g, v in grades.items())
    parts = entry.detail.get("parts")
    maximum = {FUGL_MEYER: 66, ARAT: 57}.get(entry.scale, 10)
    text = f"{label} {entry.total}/{maximum}"
    if parts:
        text += " (" + ", ".join(f"{k} {v}" for k, v in parts.items()) + ")"
    return text


def cmd_scales_show(args: argparse.Namespace) -> int:
    registry = registry_for(args)
    if args.history:
        entries = registry.scale_entries(args.code, args.session)
        for e in entries:
            print(f"session {e.session_number:>3}  {e.recorded_at:%Y-%m-%d %H:%M} UTC  "
                  f"{e.rater:<16}  {_scale_text(e)}")
        if not entries:
            print(f"patient {args.code} has no scales recorded yet")
        return 0
    per_session = registry.session_scales(args.code)
    if args.session is not None:
        registry.session(args.code, args.session)  # refuses a session that does not exist
        per_session = {args.session: per_session.get(args.session, {})}
    if not any(per_session.values()):
        print(f"patient {args.code} has no scales recorded yet")
        return 0
    for number, scales in sorted(per_session.items()):
        print(f"session {number}:")
        for scale in SCALES:
            if scale in scales:
                e = scales[scale]
                print(f"  {_scale_text(e)}  ({e.rater}, {e.recorded_at:%Y-%m-%d %H:%M} UTC)")
    return 0


# ------------------------------------------------------------------ notes
def cmd_note(args: argparse.Namespace) -> int:
    registry = registry_for(args)
    note = registry.add_note(args.code, args.session, args.text, author=args.by,
                             trial_id=args.trial)
    where = f"trial {note.trial_id}" if note.trial_id else f"session {note.session_number}"
    print(f"note {note.id} on {args.code} {where} kept")
    return 0


def cmd_notes(args: argparse.Namespace) -> int:
    registry = registry_for(args)
    notes = registry.notes(args.code, args.session)
    if not notes:
        print(f"patient {args.code} has no notes yet")
    for n in notes:
        where = f"trial {n.trial_id}" if n.trial_id else "session"
        print(f"session {n.session_number:>3}  {where:<11} {n.written_at:%Y-%m-%d %H:%M} UTC  "
              f"{n.author}: {n.text}")
    return 0


# ------------------------------------------------------------------ validity
def cmd_mark(args: argparse.Namespace) -> int:
    registry = registry_for(args)
    mark = registry.mark_trial(args.trial_id, valid=args.valid, reason=args.reason,
                               by=args.by)
    state = "valid again" if mark.valid else "invalid"
    print(f"trial {mark.trial_id} marked {state}: {mark.reason}")
    return 0


# ------------------------------------------------------------------ corrections
def cmd_correct(args: argparse.Namespace) -> int:
    registry = registry_for(args)
    registry.correct_patient(args.code, args.field, typed_value(args.field, args.value),
                             reason=args.reason, by=args.by)
    last = registry.corrections(args.code)[-1]
    print(f"{args.code} {last.field}: {last.old_value!r} → {last.new_value!r} (kept in the "
          "audit trail)")
    return 0


def cmd_corrections(args: argparse.Namespace) -> int:
    registry = registry_for(args)
    trail = registry.corrections(args.code)
    if not trail:
        print(f"patient {args.code} has no corrections")
    for c in trail:
        print(f"{c.corrected_at:%Y-%m-%d %H:%M} UTC  {c.corrected_by:<16} {c.field}: "
              f"{c.old_value!r} → {c.new_value!r}  ({c.reason})")
    return 0

