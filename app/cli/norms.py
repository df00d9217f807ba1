"""`rehab norms`: the normative models Z-scores and task scores are computed against.

`show` prints a norms file (or the data folder's), `fit` fits one from healthy controls
(a table, or their assessment trial files) with its cross-validated calibration, `score`
prints an assessment trial's Z-scores and task score, `use` makes a file the data folder's
norms (the one before kept), `mdc` adds MDC95 per figure and task score from test-retest
data.
docs/norms.md documents the file and the formulas.
"""

from __future__ import annotations

import argparse
import json

from app.cli.common import EXIT_OK, CommandError, absolute, data_dir_for, output_path, subcommands


def add_norms_commands(commands) -> None:
    norms = commands.add_parser(
        "norms", help="normative models: show, fit from controls, use, MDC from retests",
        description="The normative models figures are scored against (docs/norms.md).")
    actions = subcommands(norms)
    p = actions.add_parser("show", help="a norms file, or the data folder's norms",
                           description="Print a norms file's source, covariates, figures, "
                                       "task scores and calibration; without FILE, the "
                                       "norms the data folder uses.")
    p.add_argument("file", nargs="?", help="a norms file (default: the data folder's)")
    p.set_defaults(func=cmd_show)
    p = actions.add_parser("fit", help="fit norms from a table of healthy controls",
                           description="Fit a normative model from healthy controls "
                                       "(one CSV row per person: subject, age_years, sex, "
                                       "handedness, tested_side, robot, then figure keys) "
                                       "and print its k-fold cross-validated calibration.")
    given = p.add_mutually_exclusive_group(required=True)
    given.add_argument("--controls", help="the controls' table (CSV)")
    given.add_argument("--trials", help="a folder of the controls' assessment trial files "
                                        "(searched recursively)")
    p.add_argument("--people", help="with --trials: the controls' birth year, sex and "
                                    "handedness (CSV subject,birth_year,sex,handedness; "
                                    "default: the data folder's registry)")
    p.add_argument("--source", required=True,
                   help="who measured which healthy people, when (printed on every report)")
    p.add_argument("--simulated", action="store_true",
                   help="the controls are virtual: every report says so")
    p.add_argument("--transform", default="auto",
                   choices=("auto", "box-cox", "yeo-johnson", "none"),
                   help="each figure's transform to normality (auto: Box-Cox when every "
                        "value is positive, else Yeo-Johnson)")
    p.add_argument("--folds", type=int, default=5, help="cross-validation folds (default 5)")
    p.add_argument("--seed", type=int, default=0, help="the folds' shuffle (default 0)")
    p.add_argument("--output", required=True, help="the norms file to write (.json)")
    p.add_argument("--overwrite", action="store_true", help="replace an existing file")
    p.set_defaults(func=cmd_fit)
    p = actions.add_parser("score", help="an assessment trial's Z-scores and task score",
                           description="Score an assessment trial file's figures against "
                                       "the norms: each figure's Z-score and the task "
                                       "score. The person is the registry's patient with "
                                       "the file's subject code, or given by --birth-year, "
                                       "--sex and --handedness (a virtual patient).")
    p.add_argument("trials", nargs="+", help="assessment trial files (.h5), or registered "
                                             "trials' ids (`rehab assess show CODE`)")
    p.add_argument("--norms", help="a norms file (default: the data folder's)")
    p.add_argument("--birth-year", type=int, help="the person's birth year (with --sex and "
                                                  "--handedness, instead of the registry)")
    p.add_argument("--sex", choices=("female", "male"), help="with --birth-year")
    p.add_argument("--handedness", choices=("right", "left"),
                   help="the dominant hand, with --birth-year")
    p.add_argument("--json", action="store_true", help="one JSON object per trial")
    p.set_defaults(func=cmd_score)
    p = actions.add_parser("use", help="make a norms file the data folder's norms",
                           description="Verify a norms file and make it the norms this data "
                                       "folder's reports score against; the norms used "
                                       "before are kept beside it.")
    p.add_argument("file", help="the norms file")
    p.set_defaults(func=cmd_use)
    p = actions.add_parser("mdc", help="add MDC95 from test-retest data to a norms file",
                           description="From a test-retest table (the controls' columns "
                                       "plus `session`, 1 or 2, two rows per person), "
                                       "compute ICC(2,1), SEM and MDC95 per figure and "
                                       "task score, and write the norms with them.")
    p.add_argument("retest", nargs="?", help="the test-retest table (CSV)")
    p.add_argument("--trials", help="instead of a table: a folder of assessment trial files, "
                                    "each person's first two sessions")
    p.add_argument("--people", help="with --trials: as for `rehab norms fit`")
    p.add_argument("--norms", required=True, help="the norms file to add the MDC95 to")
    p.add_argument("--output", required=True, help="the norms file to write (.json)")
    p.add_argument("--overwrite", action="store_true", help="replace an existing file")
    p.set_defaults(func=cmd_mdc)


def _load(text: str):
    from app.norms import load_norms

    if not text.strip():
        raise CommandError("the norms file is empty: give a path")
    return load_norms(absolute(text))


def cmd_show(args: argparse.Namespace) -> int:
    from app.norms import SIMULATED_LABEL
    from app.norms.fitting import calibration_lines
    from app.norms.in_use import norms_in_use

    if args.file is not None:
        model = _load(args.file)
    else:
        model = norms_in_use(data_dir_for(args))
        if model is None:
            raise CommandError("this data folder uses no norms and the console ships none: "
                               "`rehab norms use FILE`")
    print(f"norms: {model.path}")
    print(f"source: {model.source}")
    if model.simulated:
        print(f"SIMULATED — {SIMULATED_LABEL.split(' — ', 1)[1]}")
    spec = model.covariates
    print(f"controls: age {spec.age_range[0]:g}–{spec.age_range[1]:g} years; " + "; ".join(
        f"{name} {', '.join(levels)}" for name, levels in spec.levels.items()))
    print(f"{'figure':<36} {'transform':<18} {'n':>5} {'resid SD':>9} {'worse':<7} "
          f"{'MDC95':>9} {'ICC':>6}")
    for key, f in model.figures.items():
        t = f.transform
        kind = t.kind if t.kind == "none" else f"{t.kind} λ={t.lam:.3g}"
        mdc = "" if f.mdc95 is None else f"{f.mdc95:.4g}"
        print(f"{key:<36} {kind:<18} {f.regression.n:>5} {f.regression.residual_sd:>9.4g} "
              f"{f.worse:<7} {mdc:>9} {_icc(f.icc):>6}{_nil(model, key)}")
    for task, t in model.tasks.items():
        mdc = "" if t.mdc95 is None else f", MDC95 {t.mdc95:.3g}"
        icc = "" if t.icc is None else f", ICC {t.icc:.3f}"
        print(f"task score {task}: {', '.join(t.figures)} (n {t.n}{mdc}{icc})"
              f"{_nil(model, 'task:' + task)}")
    _said_once(any(model.reliability_note(k) for k in (
        *model.figures, *(f"task:{t}" for t in model.tasks))))
    if model.notes:
        print(model.notes)
    held = model.calibration.get("held_out") if isinstance(model.calibration, dict) else None
    if isinstance(held, dict) and held:
        print(f"calibration: {model.calibration.get('method', '')}")
        try:
            for line in calibration_lines(held):
                print(line)
        except (KeyError, TypeError, ValueError):
            print("(the file's calibration is not in the form `rehab norms fit` writes)")
    return EXIT_OK


def _icc(icc: float | None) -> str:
    return "" if icc is None else f"{icc:.3f}"


def _nil(model, key: str) -> str:
    """"  <NO_RELIABILITY>" beside an MDC95 whose ICC is ≤ 0, else ""."""
    from app.norms.model import NO_RELIABILITY

    return f"  {NO_RELIABILITY}" if model.reliability_note(key) else ""


def _said_once(marked: bool) -> None:
    """Under a table that marked an MDC95 NO_RELIABILITY: what that means, once."""
    from app.norms.model import NO_RELIABILITY_SAID

    if marked:
        print(NO_RELIABILITY_SAID)


def cmd_fit(args: argparse.Namespace) -> int:
    from app.norms import write_norms
    from app.norms.fitting import calibration_lines, fit_norms, read_controls_table

    source = absolute(args.controls if args.controls is not None else args.trials)
    output = output_path(args, args.output, overwrite=args.overwrite, inputs=(source,),
                         suffixes=(".json",))
    if not 2 <= args.folds <= 100:
        raise CommandError(f"--folds {args.folds}: give 2 to 100")
    if args.controls is not None:
        if args.people is not None:
            raise CommandError("--people goes with --trials: a controls table holds the "
                               "covariates itself")
        controls = read_controls_table(source)
    else:
        controls = _controls_from_trials(args, source, retest=False)
    report = fit_norms(controls, args.source, simulated=args.simulated,
                       transform=args.transform, folds=args.folds, seed=args.seed)
    write_norms(output, report.document, overwrite=args.overwrite)
    n = max(f["n"] for f in report.document["figures"].values())
    print(f"fitted norms on {n} controls: {len(report.document['figures'])} "
          f"figures, {len(report.document['tasks'])} task scores; written to {output}")
    print(report.document["calibration"]["method"] + " (held-out Z-scores; task scores "
          "one-sided):")
    for line in calibration_lines(report.document["calibration"]["held_out"]):
        print(line)
    for key, why in report.left_out.items():
        print(f"left out {key}: {why}")
    for key, note in report.notes.items():
        print(f"note {key}: {note}")
    return EXIT_OK


def cmd_use(args: argparse.Namespace) -> int:
    from app.norms.in_use import use_norms

    if not args.file.strip():
        raise CommandError("the norms file is empty: give a path")
    model, moved = use_norms(data_dir_for(args), absolute(args.file))
    print(f"this data folder's reports now score against: {model.label}")
    if moved is not None:
        print(f"the norms used before are kept as {moved}")
    return EXIT_OK


def cmd_mdc(args: argparse.Namespace) -> int:
    from app.norms import write_norms
    from app.norms.fitting import read_controls_table
    from app.norms.model import NO_RELIABILITY
    from app.norms.retest import ICC_FORM, retest_reliability, with_mdc

    if (args.retest is None) == (args.trials is None):
        raise CommandError("give the test-retest table or --trials FOLDER (one of them)")
    norms_path = absolute(args.norms)
    retest_path = absolute(args.retest if args.retest is not None else args.trials)
    output = output_path(args, args.output, overwrite=args.overwrite,
                         inputs=(norms_path, retest_path), suffixes=(".json",))
    model = _load(args.norms)
    if args.retest is not None:
        if args.people is not None:
            raise CommandError("--people goes with --trials: a retest table holds the "
                               "covariates itself")
        retest = read_controls_table(retest_path, sessions=True)
    else:
        retest = _controls_from_trials(args, retest_path, retest=True)
    result = retest_reliability(model, retest)
    if not result.found:
        raise CommandError("no figure or task score has enough test-retest pairs: " + "; ".join(
            f"{k}: {v}" for k, v in list(result.skipped.items())[:3]))
    document = with_mdc(json.loads(norms_path.read_text(encoding="utf-8")), result.found)
    write_norms(output, document, overwrite=args.overwrite)
    print(f"{'figure or task score':<36} {'pairs':>5} {f'ICC({ICC_FORM})':>9} {'SEM':>9} "
          f"{'MDC95':>9}")
    for key, r in result.found.items():
        nil = f"  {NO_RELIABILITY}" if r.icc <= 0 else ""
        print(f"{key:<36} {r.pairs:>5} {r.icc:>9.3f} {r.sem:>9.4g} {r.mdc95:>9.4g}{nil}")
    _said_once(any(r.icc <= 0 for r in result.found.values()))
    for key, why in result.left_out.items():
        print(f"{key}: {why}")
    for key, why in result.skipped.items():
        print(f"no MDC95 for {key}: {why}")
    print(f"written to {output}")
    return EXIT_OK


def _controls_from_trials(args: argparse.Namespace, folder, *, retest: bool):
    """Controls (or test-retest data) from a folder of assessment trial files, their
    covariates from --people or the data folder's registry; what was left out is said."""
    from app.norms import controls as c
    from core.assessment import FIGURES

    invalid = {}
    if args.people is not None:
        people = c.people_from_table(absolute(args.people))
    else:
        from app.cli.common import registry_for

        registry = registry_for(args)
        people = c.people_from_registry(registry)
        invalid = c.invalid_files(registry)
    files = c.trial_files(folder)
    trials, skipped = c.read_assessments(files, invalid)
    if not trials:  # said here: the fit's own refusal would only say none was found
        _no_assessments(folder, len(files), skipped)
    if retest:
        controls, left = c.retest_from_trials(trials, people, FIGURES)
    else:
        controls, left = c.controls_from_trials(trials, people, FIGURES)
    for where, why in {**skipped, **left}.items():
        if why != "not an assessment trial":
            print(f"not used: {where}: {why}")
    print(f"{len(trials)} assessment trials of {len({t.subject for t in trials})} people read "
          f"from {folder}")
    return controls


def _no_assessments(folder, files: int, skipped: dict[str, str]) -> None:
    """The one line for a folder that gave no assessment trial to fit: how many trial files
    it holds, and why the assessments among them were left out (the first's reason)."""
    left = {where: why for where, why in skipped.items() if why != "not an assessment trial"}
    if not left:
        raise CommandError(f"no assessment trial below {folder} ({files} trial file(s), none "
                           "an assessment's): give the folder of the controls' assessment "
                           "trials (`rehab assess run` records them)")
    # a file marked invalid is left out before it is known to be an assessment's
    where, why = next((item for item in left.items() if not item[1].startswith("marked")),
                      next(iter(left.items())))
    raise CommandError(f"no assessment trial below {folder} can be used: {len(left)} left "
                       f"out, e.g. {where}: {why}")


def cmd_score(args: argparse.Namespace) -> int:
    from app.norms.controls import Person, people_from_registry
    from app.norms.in_use import norms_in_use
    from app.norms.scoring import lines, score_trial

    given = [args.birth_year, args.sex, args.handedness]
    if any(v is not None for v in given) and not all(v is not None for v in given):
        raise CommandError("give --birth-year, --sex and --handedness together (or none: "
                           "the registry's patient)")
    if args.birth_year is not None and not 1880 <= args.birth_year <= 2200:
        raise CommandError(f"--birth-year {args.birth_year}: give a year")
    norms = _load(args.norms) if args.norms is not None else norms_in_use(data_dir_for(args))
    if norms is None:
        raise CommandError("this data folder uses no norms and the console ships none: give "
                           "--norms FILE or `rehab norms use FILE`")
    people = {}

    def registered_people():
        if not people:
            from app.cli.common import registry_for

            people.update(people_from_registry(registry_for(args)))
        return people

    for text in args.trials:
        path = _trial_file(args, text)
        if args.birth_year is not None:
            person = Person(args.birth_year, args.sex, args.handedness)
        else:
            person = _registered(path, registered_people)
        scores = score_trial(path, norms, person)
        if args.json:
            print(json.dumps(_as_json(scores), allow_nan=False))
        else:
            print("\n".join(lines(scores)))
    return EXIT_OK


def _trial_file(args: argparse.Namespace, text: str):
    """The file a TRIALS argument names: a registered trial's, for an id (as `rehab pose`
    takes one), else the path as given (an id typed was read as a file named '11')."""
    from app.cli.common import registry_for, trial_id_or_none

    number = trial_id_or_none(text)
    if number is None:
        return absolute(text)
    registry = registry_for(args)
    return registry.trial_path(registry.trial(number))


def _registered(path, registered_people):
    """The registry's covariates of the trial's subject (`registered_people()`, the
    registry's, opened only for a registered patient's trial). A trial that is no
    assessment is refused first: asking for a birth year it would not use sent the user to
    record one, only to be told next that the trial cannot be scored."""
    from app.records.datadir import CODE_PATTERN
    from app.trials.reader import read_trial

    data = read_trial(path, channels=())
    if not (getattr(data.parameters, "assessment", "") if data.parameters else ""):
        raise CommandError(f"{path} is not an assessment trial (its parameters name no "
                           "task): norms score assessments only (`rehab assess run`)")
    code = data.subject.code if data.subject else None
    if not (isinstance(code, str) and CODE_PATTERN.fullmatch(code)):
        raise CommandError(f"{path}: its subject {code!r} is no registered patient: give "
                           "--birth-year, --sex and --handedness")
    people = registered_people()
    if code not in people:
        raise CommandError(f"{path}: patient {code} has no birth year, sex and handedness in "
                           f"the registry: record them (`rehab correct {code} birth_year "
                           "YEAR --reason R --by B`, and sex, handedness), or give "
                           "--birth-year, --sex and --handedness")
    return people[code]


def _as_json(scores) -> dict:
    p = scores.person
    task = scores.task_score
    return {
        "trial": str(scores.path), "task": scores.task,
        "person": {"age_years": p.age_years, "sex": p.sex, "handedness": p.handedness,
                   "tested_side": p.tested_side, "robot": p.robot},
        "figures": {k: {"value": z.value, "z": z.z, "worse_z": z.worse_z,
                        "extrapolated": z.extrapolated} for k, z in scores.figures.items()},
        "task_score": None if task is None else {"score": task.score, "z_task": task.z_task,
                                                 "distance": task.distance},
        "why_no_task_score": scores.why_no_task_score,
        "not_performed": scores.not_performed,
        "unscored": scores.unscored,
        "norms": scores.label,
    }
