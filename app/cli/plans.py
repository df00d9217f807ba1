"""`rehab plan …`: session plans on the command line. The templates, a template copied to a
patient, the patient's plan shown and a block changed for the day, the plan run on the
simulator through the live loop (app.plans.live: the same processes as the window's),
and the dose a run delivered (app.plans.dose).

Values are SI as in the plan's data (core.plan): seconds, radians, metres, levels 0–1;
the listing shows them in the clinic's units too (minutes, degrees, percent).
"""

from __future__ import annotations

import argparse
import math

from app.cli.common import EXIT_OK, CommandError, record_id, registry_for, subcommands
from app.units import assistance_percent


def add_plan_commands(commands) -> None:
    parser = commands.add_parser(
        "plan", help="session plans: templates, a patient's plan, run it, its dose",
        description="Session plans: blocks of exercise with rests, copied from a template "
                    "to a patient, changed for the day, run on the simulator, and the dose "
                    "each run delivered.")
    sub = subcommands(parser)
    templates = sub.add_parser("templates", help="list the built-in plan templates",
                               description="List the built-in plan templates and their "
                                           "blocks.")
    templates.set_defaults(func=cmd_templates)
    copy = sub.add_parser("copy", help="copy a template to a patient (their plan for today)",
                          description="Copy a template to a patient: it becomes their plan.")
    copy.add_argument("template", help="a template's name (`rehab plan templates`)")
    copy.add_argument("code", help="the patient's code")
    copy.set_defaults(func=cmd_copy)
    show = sub.add_parser("show", help="show a patient's plan (their latest) and its history",
                          description="Show a patient's current plan, block by block.")
    show.add_argument("code", help="the patient's code")
    show.add_argument("--plan", type=record_id, help="another of the patient's plans, by id")
    show.set_defaults(func=cmd_show)
    change = sub.add_parser(
        "change", help="change one block of a patient's plan for today (a new plan)",
        description="Change one block of the patient's current plan; the plan is kept as "
                    "it was and the changed one becomes the current. Fields in SI: "
                    "repetitions, active_s, duration_s (s a lap), assistance_level (0-1), "
                    "assist, tolerance_rad, rest_s, rounds, shape, game, radius_m, name.")
    change.add_argument("code", help="the patient's code")
    change.add_argument("block", type=int, help="the block's number, from 1")
    change.add_argument("changes", nargs="+", metavar="FIELD=VALUE",
                        help="e.g. repetitions=5 rest_s=30 assistance_level=0.6")
    change.set_defaults(func=cmd_change)
    run = sub.add_parser(
        "run", help="run the patient's plan on the simulator (the live loop)",
        description="Run the patient's current plan on the simulator with a virtual "
                    "patient, through the live loop and recorder as the window does: each "
                    "block's trials registered and saved, the rests timed, the dose "
                    "printed.")
    run.add_argument("code", help="the patient's code")
    from device.sim.patient_parameters import PATIENT_KINDS

    run.add_argument("--patient", choices=PATIENT_KINDS, default="healthy",
                     help="virtual patient (default healthy)")
    run.add_argument("--seed", type=int, default=None,
                     help="one seed for every trial (default: a new one each trial)")
    run.add_argument("--stop-after", type=float, default=None, metavar="S",
                     help="press Stop after S seconds of the run (an unattended run's "
                          "limit; the plan ends 'stopped')")
    run.set_defaults(func=cmd_run)
    dose = sub.add_parser("dose", help="the dose of a patient's plan runs, from the files",
                          description="Movements, active time and rest per block of a "
                                      "patient's plan run (the latest, or --run), counted "
                                      "from the trial files, beside the plan's.")
    dose.add_argument("code", help="the patient's code")
    dose.add_argument("--run", type=record_id, help="a run's id (default: the latest)")
    dose.set_defaults(func=cmd_dose)


def cmd_templates(args: argparse.Namespace) -> int:
    from app.plans.templates import load_template, template_names

    for name in template_names():
        template = load_template(name)
        print(f"{name}: {template.plan.name}. {template.about}")
        for line in _blocks(template.plan):
            print(f"  {line}")
    return EXIT_OK


def cmd_copy(args: argparse.Namespace) -> int:
    from app.plans.templates import load_template
    from core.trial import TrialParameters

    registry = registry_for(args)
    # fitted to the setup a plan run starts from (app.plans.live.LivePlan's)
    base = TrialParameters().replace(**registry.patient(args.code).trial_overrides())
    template = load_template(args.template, fit_to=base)
    stored = registry.save_plan(args.code, template.plan, template=template.name)
    print(f"Plan {stored.id} for patient {args.code}: {stored.plan.name} (from the template "
          f"{template.name}), {len(stored.plan.blocks)} blocks")
    for line in template.fitted:
        print(f"  fitted to the patient: {line}")
    return EXIT_OK


def cmd_show(args: argparse.Namespace) -> int:
    registry = registry_for(args)
    stored = _plan_of(registry, args.code, args.plan)
    origin = f", changed from plan {stored.based_on}" if stored.based_on else ""
    origin += f", template {stored.template}" if stored.template else ""
    print(f"Plan {stored.id} of patient {args.code}: {stored.plan.name} (saved "
          f"{stored.created_at:%Y-%m-%d %H:%M} UTC{origin})")
    for line in _blocks(stored.plan):
        print(f"  {line}")
    plan = stored.plan
    print(f"  planned: {plan.planned_movements()} movements, "
          f"{plan.planned_active_s() / 60:.1f} min of exercise, "
          f"{plan.planned_rest_s() / 60:.1f} min of rest")
    return EXIT_OK


def cmd_change(args: argparse.Namespace) -> int:
    from core.plan import Block

    registry = registry_for(args)
    stored = _plan_of(registry, args.code, None)
    if not 1 <= args.block <= len(stored.plan.blocks):
        raise CommandError(f"block {args.block}: plan {stored.id} has blocks 1-"
                           f"{len(stored.plan.blocks)}")
    values = stored.plan.blocks[args.block - 1].to_dict()
    for change in args.changes:
        name, sep, text = change.partition("=")
        if not sep or name not in values:
            raise CommandError(f"{change!r}: give FIELD=VALUE with a block's field: "
                               f"{', '.join(sorted(values))}")
        values[name] = _value(name, text)
    if "active_s" in {c.partition("=")[0] for c in args.changes} and values["active_s"]:
        values["repetitions"] = None  # by time now, unless laps were given too
    block = Block.from_dict(values, f"block {args.block}")
    changed = registry.change_block(stored.id, args.block - 1, block)
    print(f"Plan {changed.id} for patient {args.code} (plan {stored.id} with block "
          f"{args.block} changed):")
    print(f"  {_blocks(changed.plan)[args.block - 1]}")
    return EXIT_OK


def cmd_run(args: argparse.Namespace) -> int:
    from app.plans.dose import run_dose
    from app.plans.live import LivePlan
    from device.loop.client import DeviceClient
    from device.loop.messages import BackendConfig

    if args.seed is not None and args.seed < 0:
        raise CommandError(f"--seed {args.seed}: give a whole number from 0")
    if args.stop_after is not None and not (math.isfinite(args.stop_after)
                                            and args.stop_after > 0):
        raise CommandError(f"--stop-after {args.stop_after}: give seconds above 0")
    registry = registry_for(args)
    stored = _plan_of(registry, args.code, None)
    backend = BackendConfig(patient=args.patient, seed=args.seed)
    said = [""]

    def watch(live, state) -> None:
        if args.stop_after is not None and live.clock() - started[0] > args.stop_after \
                and state.phase != "ended":
            live.press_stop()
        line = state.line()
        if state.phase != "resting" and line != said[0]:
            said[0] = line
            print(line, flush=True)

    with DeviceClient() as client:
        live = LivePlan(registry, stored, client, backend)
        started = [live.clock()]
        print(f"Running plan {stored.id} ({stored.plan.name}) as run {live.run_id} on the "
              f"simulator, {args.patient} virtual patient", flush=True)
        result = live.run(watch)
    print(f"Run {result.run_id}: {result.outcome}{': ' + result.reason if result.reason else ''}"
          f" in {result.elapsed_s:.1f} s, {len(result.trial_ids)} trials")
    dose = run_dose(registry, result.run_id)
    for line in dose.table():
        print(line)
    for note in dose.notes:
        print(f"  note: {note}")
    return EXIT_OK


def cmd_dose(args: argparse.Namespace) -> int:
    from app.plans.dose import run_dose

    registry = registry_for(args)
    runs = registry.plan_runs_for_patient(args.code)
    if args.run is not None:
        runs = [r for r in runs if r.id == args.run]
        if not runs:
            raise CommandError(f"patient {args.code} has no plan run {args.run}; `rehab plan "
                               f"dose {args.code}` shows their latest")
    if not runs:
        raise CommandError(f"patient {args.code} has run no plan yet: `rehab plan run "
                           f"{args.code}` runs their plan")
    run = runs[-1]
    dose = run_dose(registry, run.id)
    reason = f" ({run.end_reason})" if run.end_reason else ""
    print(f"Run {run.id} of plan {run.plan_id}, {run.started_at:%Y-%m-%d %H:%M} UTC: "
          f"{run.status}{reason}")
    for line in dose.table():
        print(line)
    for note in dose.notes:
        print(f"  note: {note}")
    return EXIT_OK


def _plan_of(registry, code: str, plan_id: int | None):
    if plan_id is not None:
        stored = registry.plan(plan_id)
        if stored.patient_code != code:
            raise CommandError(f"plan {plan_id} is not a plan of patient {code}")
        return stored
    stored = registry.current_plan(code)
    if stored is None:
        raise CommandError(f"patient {code} has no plan: copy a template to them first "
                           f"(`rehab plan templates`, then `rehab plan copy NAME {code}`)")
    return stored


def _value(name: str, text: str):
    """A field's value from its text: None, a whole number, a number or text."""
    if text.lower() in ("none", ""):
        return None
    if name in ("shape", "assist", "game", "name"):
        return text
    try:
        return int(text) if name in ("repetitions", "rounds") else float(text)
    except ValueError:
        raise CommandError(f"{name}={text!r}: give a number") from None


def _laps(n: int) -> str:
    return f"{n} lap" if n == 1 else f"{n} laps"


def _blocks(plan) -> list[str]:
    """One line per block in the clinic's units."""
    lines = []
    for k, b in enumerate(plan.blocks, 1):
        amount = (_laps(b.repetitions) if b.repetitions is not None
                  else f"{b.active_s / 60:g} min ({_laps(b.laps)})")
        rounds = f" × {b.rounds} rounds" if b.rounds > 1 else ""
        game = f" game {b.game}" if b.game else ""
        size = f", radius {b.radius_m * 100:g} cm" if b.radius_m is not None else ""
        rest = f", rest {b.rest_s:g} s" if k < len(plan.blocks) else ""
        level = assistance_percent(b.assistance_level)
        lines.append(f"{k}. {b.name or b.shape}: {b.shape}{game}{size}, {amount}{rounds} at "
                     f"{b.duration_s:g} s a lap, {b.assist} {level}, tolerance "
                     f"{math.degrees(b.tolerance_rad):.0f}°{rest}")
    return lines
