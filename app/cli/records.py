"""The clinic's records on the command line: `rehab patients` and `rehab trials`.

Each command opens the registry of the data folder (REHAB_DATA_DIR, the setting, or the
default; `--data-dir` overrides) and prints plain columns. Names are shown only by
`patients`, which is the clinic's own view; `--no-names` hides them there too.
"""

from __future__ import annotations

import argparse
import math

from app.cli.common import CommandError, mm, num, registry_for, subcommands
from app.games.figures import game_line
from app.records.registry import HANDEDNESS, SEXES
from app.units import assistance_percent, cm
from core.trial import SIDES


# ------------------------------------------------------------------ patients
def add_patient_commands(commands) -> None:
    parser = commands.add_parser("patients", help="list, find or register patients",
                                 description="List, find or register patients.")
    parser.add_argument("--search", help="part of a name, or the start of a code")
    parser.add_argument("--no-names", action="store_true", help="show codes only")
    parser.set_defaults(func=cmd_patients)
    sub = subcommands(parser, required=False)
    listing = sub.add_parser("list", help="list the patients (the same as no action)",
                             description="List the registered patients.")
    listing.add_argument("--search", help="part of a name, or the start of a code")
    listing.add_argument("--no-names", action="store_true", help="show codes only")
    listing.set_defaults(func=cmd_patients)
    add = sub.add_parser("add", help="register a new patient (prints the new code)",
                         description="Register a new patient. SI units: kg and m.")
    add.add_argument("--first-name", help="kept in the registry; files carry the code")
    add.add_argument("--last-name", help="kept in the registry; files carry the code")
    add.add_argument("--birth-year", type=int, help="for the norms, e.g. 1958")
    add.add_argument("--side", choices=SIDES, help="arm trained (affected side)")
    add.add_argument("--body-mass", type=float, help="kg")
    add.add_argument("--upper-arm", type=float, help="shoulder to elbow, m")
    add.add_argument("--forearm", type=float, help="elbow to wrist, m")
    add.add_argument("--shoulder", nargs=2, type=float, metavar=("X", "Y"),
                     help="shoulder position in the robot's frame, m")
    add.add_argument("--sex", choices=SEXES, help="for the norms (app.norms)")
    add.add_argument("--handedness", choices=HANDEDNESS, help="the dominant hand")
    add.add_argument("--notes", default="", help="a note kept with the patient's record")
    add.add_argument("--same-name", action="store_true",
                     help="register a different person with the name of one registered "
                          "(else refused, as the Registration tab does)")
    add.set_defaults(func=cmd_patients_add)


def cmd_patients(args: argparse.Namespace) -> int:
    registry = registry_for(args)
    patients = (registry.search_patients(args.search) if args.search
                else registry.patients())
    if not patients:
        print("no patients" + (f" match {args.search!r}" if args.search else " yet"))
        return 0
    for p in patients:
        name = "" if args.no_names else f"  {p.last_name or ''}, {p.first_name or ''}".rstrip(", ")
        side = p.side or "-"
        mass = f"{p.body_mass_kg:g} kg" if p.body_mass_kg else "-"
        print(f"{p.code}{name:<32}  side {side:<5}  {mass}")
    return 0


PATIENT_OPTIONS = {"first_name": "--first-name", "last_name": "--last-name",
                   "birth_year": "--birth-year", "side": "--side", "sex": "--sex",
                   "handedness": "--handedness", "body_mass_kg": "--body-mass",
                   "upper_arm_m": "--upper-arm", "forearm_m": "--forearm",
                   "shoulder_m": "--shoulder", "notes": "--notes"}
"""The option each of a patient's fields is given by: a refusal names it, as typed."""


def cmd_patients_add(args: argparse.Namespace) -> int:
    values = dict(birth_year=args.birth_year, side=args.side, body_mass_kg=args.body_mass,
                  upper_arm_m=args.upper_arm, forearm_m=args.forearm,
                  shoulder_m=tuple(args.shoulder) if args.shoulder else None,
                  notes=args.notes, sex=args.sex, handedness=args.handedness)
    _check_patient(args.first_name, args.last_name, values)
    # the first patient starts a registry (in a new or empty folder only): once the
    # patient's values are found good, so a refused first patient leaves no registry
    registry = registry_for(args, create=True)
    if (args.first_name or args.last_name) and not args.same_name:
        namesakes = registry.find_patients(args.first_name or "", args.last_name or "")
        if namesakes:  # the same person twice would split their record in two
            known = "; ".join(f"{p.code} ({p.display_name}"
                              + (f", born {p.birth_year}" if p.birth_year else "") + ")"
                              for p in namesakes)
            raise CommandError(f"already registered: {known}. Use that code, or give "
                               "--same-name to register a different person with this name")
    patient = registry.create_patient(args.first_name, args.last_name, **values)
    print(patient.code)
    return 0


def _check_patient(first_name, last_name, values: dict) -> None:
    """The registry's checks of a new patient's values, before any registry is opened;
    a refusal names the option typed ('--upper-arm (upper_arm_m) = 30 …', in m)."""
    from app.errors import InvalidRecordError
    from app.records.registry.patients import _patient_values

    try:
        _patient_values(first_name=first_name, last_name=last_name, **values)
    except InvalidRecordError as exc:
        field, said = str(exc).partition(" ")[::2]
        option = PATIENT_OPTIONS.get(field.split("[")[0])
        if option is None:
            raise
        raise CommandError(f"{option} ({field}) {said}") from None


# ------------------------------------------------------------------ trials
def add_trials_command(commands) -> None:
    parser = commands.add_parser("trials", help="a patient's trials with their key figures",
                                 description="List a patient's trials: session, trial, "
                                             "status, exercise and key figures.")
    parser.add_argument("code", help="the patient's code (see `rehab patients`)")
    parser.set_defaults(func=cmd_trials)


def cmd_trials(args: argparse.Namespace) -> int:
    registry = registry_for(args)
    trials = registry.trials_for_patient(args.code)
    if not trials:
        print(f"patient {args.code} has no trials yet")
        return 0
    proposals = {p.trial_id: p for p in registry.proposals_for_patient(args.code)}
    invalid = registry.invalid_trials(args.code)
    notes: dict[int, list] = {}
    for note in registry.notes(args.code):
        if note.trial_id is not None:
            notes.setdefault(note.trial_id, []).append(note)
    print(f"{'id':>5} {'session':>7} {'trial':>5}  {'started (UTC)':<20}{'status':<15}"
          f"{'exercise':<26}{'RMSE x/y mm':>13}{'direction %':>12}{'led %':>7}  "
          f"{'mode':<11} assistance")
    for t in trials:
        p = t.parameters
        task = p.get("assessment", "")
        if task:
            # a task's fixed protocol: its figures are `rehab assess show`'s, not the
            # exercise's (an RMSE from a path the patient was not asked to follow)
            exercise, rmse, direction, led = f"assessment: {task}", "–", None, None
        else:
            exercise = f"{p.get('shape', '?')} r {cm(p.get('radius_m', math.nan))}, " \
                       f"{p.get('duration_s', math.nan):g} s"
            rmse = f"{mm(t.metrics.get('rmse_x_m'))}/{mm(t.metrics.get('rmse_y_m'))}"
            direction = t.metrics.get("directional_performance_pct")
            led = t.metrics.get("led_pct")
        started = t.started_at.strftime("%Y-%m-%d %H:%M") if t.started_at else "-"
        print(f"{t.id:>5} {t.session_number:>7} {t.number:>5}  {started:<20}{t.status:<15}"
              f"{exercise:<26}{rmse:>13}{num(direction):>12}{num(led):>7}  "
              f"{t.assist:<11} {_levels(t)}")
        if t.backend:
            station = f" at station {t.station}" if t.station else ""
            stored = f"; a copy in the trial store {t.stored_in}" if t.stored_in else ""
            print(f"{'':>21}robot: {t.backend}{station}{stored}")
        game = game_line(p, t.metrics)
        if game:
            print(f"{'':>21}{game}")
        if task:
            print(f"{'':>21}figures: rehab assess show {args.code} --task {task}")
        stored = proposals.get(t.id)
        if stored is not None and not task:  # one an assessment was given before none was
            print(f"{'':>21}proposed: {stored.proposal.get('reason', '?')} "
                  f"({stored.decision})")
        if t.end_reason:
            print(f"{'':>21}ended: {t.end_reason}")
        if t.id in invalid:
            mark = invalid[t.id]
            print(f"{'':>21}INVALID: {mark.reason} ({mark.marked_by}, "
                  f"{mark.marked_at:%Y-%m-%d %H:%M} UTC)")
        for note in notes.get(t.id, ()):
            print(f"{'':>21}note: {note.text} ({note.author})")
    return 0


def _levels(trial) -> str:
    """The levels the trial ran ('100 % → 60 % at 5.8 s'), or the built one when the
    registry does not know them (a trial before it kept them, or not finished)."""
    if trial.assistance is not None:
        return trial.assistance.summary()
    built = trial.parameters.get("assistance_level")
    return "-" if built is None else f"{assistance_percent(built)} as built"
