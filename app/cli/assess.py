"""`rehab assess …`: the assessment battery on the command line (issue 31). The tasks and
their protocols, a task or the whole battery run on the simulator for a registered patient
(each trial registered and saved as `rehab run`'s), and a patient's assessments with their
figures from the registry.

Figures are printed in SI with the unit core.assessment.FIGURES gives them.
"""

from __future__ import annotations

import argparse
from collections.abc import Mapping
from types import MappingProxyType

from app.cli.common import EXIT_OK, CommandError, next_session, registry_for, subcommands


def add_assess_commands(commands) -> None:
    parser = commands.add_parser(
        "assess", help="the assessment battery: its tasks, run them, a patient's figures",
        description="The assessment battery (visually guided reaching, circle drawing, "
                    "active range, isometric strength, position sense): each task's "
                    "protocol, a task or all of them run on the simulator for a patient, "
                    "and a patient's figures.")
    sub = subcommands(parser)
    tasks = sub.add_parser("tasks", help="list the tasks, their protocols and figures",
                           description="List every task: what the therapist does, what "
                                       "the patient is told, its trials, robot mode and "
                                       "figures.")
    tasks.set_defaults(func=cmd_tasks)
    from core.assessment import TASKS

    run = sub.add_parser(
        "run", help="run a task (or all) on the simulator for a patient",
        description="Run a task's trials, or the whole battery's, on the simulator with a "
                    "virtual patient: each trial registered for the patient and saved in "
                    "the data folder with the task's figures in its metrics.")
    run.add_argument("code", help="the patient's code")
    run.add_argument("--task", required=True, choices=(*TASKS, "all"),
                     help="the task, or all for the whole battery")
    from device.sim.patient_parameters import PATIENT_KINDS

    run.add_argument("--patient", choices=PATIENT_KINDS, default="healthy",
                     help="virtual patient (default healthy)")
    run.add_argument("--seed", type=int, default=0,
                     help="the first trial's seed, a whole number from 0 (default 0); trial "
                          "k of a task runs with seed + k")
    from core.trial import TrialParameters

    run.add_argument("--centre", nargs=2, type=float, metavar=("X", "Y"),
                     default=TrialParameters().centre_m,
                     help="the tasks' centre on the table, m (default %(default)s): move it "
                          "toward the shoulder for a patient who cannot reach round it")
    run.add_argument("--new-session", action="store_true",
                     help="register the trials in a new session of the patient's (default: "
                          "today's session goes on), e.g. the retest of a test-retest pair "
                          "(`rehab norms mdc`) recorded the same day")
    run.set_defaults(func=cmd_run)
    show = sub.add_parser("show", help="a patient's assessments and their figures",
                          description="A patient's assessment trials, task by task, with "
                                      "each one's figures as the registry holds them; "
                                      "trials marked invalid (`rehab invalid`) left out "
                                      "unless asked (--include-invalid).")
    show.add_argument("code", help="the patient's code")
    show.add_argument("--task", choices=TASKS, help="only this task")
    show.add_argument("--include-invalid", action="store_true",
                      help="also the trials marked invalid, each saying why")
    show.set_defaults(func=cmd_show)


def cmd_tasks(args: argparse.Namespace) -> int:
    from app.assessments.words import robot_task_words
    from core.assessment import task_figures
    from core.assessment.protocol import PROTOCOLS
    from core.holdtasks import ROBOT_TASKS
    from core.trial import THESIS_SUBJECT

    for task, p in PROTOCOLS.items():
        trials = (f"{p.trial_count} trials ({', '.join(p.trials)})" if p.trial_count > 1
                  else "1 trial")
        if task in ROBOT_TASKS:  # the robot leads: its timetable, as the window says it
            print(f"{task}: {p.name}. {trials}: "
                  f"{robot_task_words(p.parameters(THESIS_SUBJECT))}")
        else:
            print(f"{task}: {p.name}. {trials}, {p.repetitions} × {p.duration_s:g} s, robot "
                  f"{p.robot_mode}{' on ' + p.controller if p.controller else ''}; "
                  f"{p.shape} of {p.radius_m:g} m" + (f", {p.n_targets} targets"
                                                       if p.shape == "targets" else ""))
        print(f"  therapist: {p.therapist}")
        print(f"  patient: {p.patient}")
        print(f"  follows: {p.reference}")
        # each figure's key beside its label: a controls table's column for `rehab norms
        # fit` is the key, which no command listed
        print("  figures: " + "; ".join(f"{s.label} ({s.unit}) {s.key}"
                                         for s in task_figures(task)))
    return EXIT_OK


def cmd_run(args: argparse.Namespace) -> int:
    from app.assessments.circle_record import pairs
    from app.assessments.runner import run_battery, run_task

    if args.seed < 0:
        raise CommandError(f"--seed {args.seed}: give a whole number from 0")
    registry = registry_for(args)
    registry.patient(args.code)  # an unknown code refused before anything runs
    from core.errors import UnreachableError
    from core.trial import TrialParameters

    base = TrialParameters(centre_m=tuple(args.centre))
    options = {"registry": registry, "code": args.code, "progress": print,
               "session_number": next_session(registry, args.code) if args.new_session
               else None}
    try:
        if args.task == "all":
            runs = run_battery(args.patient, base, seed=args.seed, **options)
        else:
            runs = {args.task: run_task(args.task, args.patient, base, seed=args.seed,
                                        **options)}
    except UnreachableError as exc:
        # the refusal says "move the exercise": here that is --centre
        x, y = base.centre_m
        exc.add_note(f"move the tasks with --centre X Y, now {x:g} {y:g} m")
        raise
    for task, trials in runs.items():
        paired = pairs([(t.trial_id, t.metrics) for t in trials]) if task == "circle" else {}
        for trial in trials:
            clockwise = trial.parameters.clockwise
            _print_trial(task, _heading(task, trial.trial_id, trial.status,
                                        (trial.session_number, trial.trial_number),
                                        f"{trial.simulated_s:.0f} s simulated in "
                                        f"{trial.elapsed_s:.1f} s", clockwise),
                         _shown(task, trial.figures, clockwise, trial.trial_id in paired),
                         trial.notes)
            _print_pair(task, trial.trial_id, trial.metrics, paired,
                        {t.trial_id for t in trials})
    return EXIT_OK


def cmd_show(args: argparse.Namespace) -> int:
    from app.assessments.circle_record import pairs
    from app.norms.in_use import norms_in_use
    from app.reports.assessment_page import (
        NO_NORMS,
        assessment_page,
        missing_covariates,
        trial_covariates,
    )

    registry = registry_for(args)
    patient = registry.patient(args.code)
    assessments = [t for t in registry.trials_for_patient(args.code)
                   if t.parameters.get("assessment", "")
                   and (not args.task or t.parameters["assessment"] == args.task)]
    # as Progress, the proposals and the exports: a trial marked invalid does not count
    invalid = registry.invalid_trials(args.code)
    trials = [t for t in assessments if args.include_invalid or t.id not in invalid]
    left_out = len(assessments) - len(trials)
    if not trials and not left_out:
        what = f"no {args.task} assessment" if args.task else "no assessment"
        print(f"Patient {args.code} has {what} yet: `rehab assess run {args.code} --task "
              f"{args.task or 'all'}` runs one on the simulator")
        return EXIT_OK
    # a damaged norms file is refused here in one line (NormsFileError: exit 2), never
    # replaced by no norms in silence
    norms = norms_in_use(registry.data_dir)
    # the tested side comes from each trial's file (trial_covariates); the registry's is
    # needed only when a file does not say it, which that trial's notes then tell
    missing = missing_covariates(patient, side_known=True) if norms is not None else ()
    circles = [t for t in assessments if t.parameters["assessment"] == "circle"]
    paired = pairs([(t.id, t.metrics) for t in circles])
    listed = {t.id for t in trials}
    for trial in trials:
        task = trial.parameters["assessment"]
        clockwise = bool(trial.parameters.get("clockwise", True))
        person, notes = None, []
        if norms is not None and not missing:
            person, notes = trial_covariates(registry, patient, trial)
            if person is None:
                notes = [*notes, "no Z-scores: neither the trial's file nor the registry says "
                         "which arm was tested"]
        scoring = {"norms": norms if person is not None else None, "person": person}
        shown = _shown(task, trial.metrics, clockwise, trial.id in paired)
        notes = [*notes, *_pair_left_out(paired.get(trial.id, ()), listed)]
        _print_trial(task, _heading(task, trial.id, trial.status,
                                    (trial.session_number, trial.number),
                                    trial.session_date.isoformat(), clockwise),
                     shown, notes, page=assessment_page(task, shown, **scoring),
                     task_score=person is not None and trial.id not in paired,
                     invalid=invalid[trial.id].reason if trial.id in invalid else "")
        _print_pair(task, trial.id, trial.metrics, paired, listed, scoring,
                    task_score=person is not None, invalid=invalid)
    if left_out:
        print(f"{left_out} trial(s) marked invalid left out (`rehab trials CODE` says why); "
              "--include-invalid shows them too")
    if missing:
        print(f"No Z-scores: the registry lacks the patient's {', '.join(missing)} "
              f"(record them: rehab correct {args.code} FIELD VALUE --reason R --by B)")
    print(NO_NORMS if norms is None else norms.label)
    return EXIT_OK


def _heading(task: str, trial_id, status: str, numbers: tuple[int, int], where: str,
             clockwise: bool) -> str:
    """A trial's heading: its registry id (what `rehab trials` lists as id and `rehab
    invalid` takes), its status, the session and the patient's trial number (`numbers`),
    then `where`; a circle trial's says which way round it drew."""
    from app.assessments.circle_record import WAY_WORDS, way_of
    from core.assessment import TASK_TITLES

    way = f", {WAY_WORDS[way_of(clockwise)]}" if task == "circle" else ""
    session, number = numbers
    return (f"{TASK_TITLES.get(task, task)} — trial id {trial_id}, {status}, session "
            f"{session}, trial {number}, {where}{way}")


def _shown(task: str, metrics: dict, clockwise: bool, paired: bool) -> dict:
    """The figures shown under a trial: a circle trial of a pair shows its own way's, the
    pair's are shown once (app.assessments.circle_record)."""
    from app.assessments.circle_record import own_figures

    return own_figures(metrics, clockwise) if task == "circle" and paired else metrics


def _print_pair(task: str, trial_id, metrics: dict, paired: dict, listed: set,
                scoring: dict | None = None, task_score: bool = False,
                invalid: Mapping = MappingProxyType({})) -> None:
    """After the last trial of a circle pair, the task's figures (both ways' mean) and its
    task score, once, with the trials they come from; none when a trial of the pair is
    not `listed` (marked invalid and left out: the mean is partly of it)."""
    from app.assessments.circle_record import pair_figures, pair_heading
    from app.reports.assessment_page import assessment_page
    from core.assessment import TASK_TITLES

    ids = paired.get(trial_id) if task == "circle" else None
    if not ids or not listed.issuperset(ids) or trial_id != max(ids):
        return
    marked = [str(i) for i in ids if i in invalid]
    figures = pair_figures(metrics)
    _print_trial(task, f"{TASK_TITLES[task]} — {pair_heading(ids)}"
                 + (f" ({', '.join(marked)} marked invalid)" if marked else ""), figures, (),
                 page=assessment_page(task, figures, **(scoring or {})),
                 task_score=task_score)


def _pair_left_out(ids, listed: set) -> list[str]:
    """Why a circle trial's pair has no task figures shown: its other trial left out."""
    out = [str(i) for i in ids if i not in listed]
    if not out:
        return []
    return [f"the task's figures (both ways round) are left out with trial {', '.join(out)}, "
            "marked invalid (--include-invalid shows them)"]


def _print_trial(task: str, heading: str, metrics: dict, notes, page=None,
                 task_score: bool = False, invalid: str = "") -> None:
    """A trial's heading, why it was marked `invalid` (when it was), its figures, each with
    its Z-score when `page` (app.reports.assessment_page.AssessmentPage) has one, its task
    score (`task_score`), the page's notes (why a figure has no Z-score) and `notes`."""
    from app.reports.assessment_page import assessment_page, figure_text

    print(heading)
    if invalid:
        print(f"  invalid: {invalid}")
    page = assessment_page(task, metrics) if page is None else page
    if not page.lines:
        print("  no figures")
    for line in page.lines:
        print(figure_text(line))
    if task_score:
        print(f"  {page.task_score}")
    # an empty page's one note is that it has no figures, said above
    for note in (*(page.notes if page.lines else ()), *notes):
        print(f"  note: {note}")
