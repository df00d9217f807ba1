"""`rehab run`: a whole trial simulated headless with a virtual patient, as fast as it goes
(app.trials.headless), its metrics printed; its file written to `--output`, or with
`--code` registered for a patient whose body sizes replace the trial options'. Without
either nothing is kept and no data folder is touched."""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

from app.cli.common import (
    EXIT_OK,
    CommandError,
    data_dir_for,
    next_session,
    output_path,
    progress_bar,
    registry_for,
)
from app.cli.trial_options import add_trial_options, trial_from_args


def add_run_command(commands) -> None:
    run_cmd = commands.add_parser(
        "run", help="simulate a whole trial headless and print its metrics (--output or "
                    "--code keeps it)",
        description="Run a trial on the simulator with a virtual patient as fast as it goes "
                    "and print the metrics table; its trial file is kept with --output, or "
                    "registered for a patient with --code (nothing is kept without either).",
    )
    add_trial_options(run_cmd)
    from device.sim.patient_parameters import PATIENT_KINDS

    run_cmd.add_argument("--patient", choices=PATIENT_KINDS, default="healthy",
                         help="virtual patient (default healthy)")
    run_cmd.add_argument("--seed", type=int, default=None,
                         help="the trial's seed (the virtual patient's draws and the sensor "
                              "noise), a whole number from 0; default: a new one for every "
                              "trial, printed and kept in its file")
    run_cmd.add_argument("--output", help="trial file to write (default: none kept; the "
                                          "figures are printed, and with --code the trial "
                                          "is registered in the data folder)")
    run_cmd.add_argument("--code", help="register the trial for this patient (their body "
                                        "sizes replace the trial options')")
    run_cmd.add_argument("--new-session", action="store_true",
                         help="with --code: register the trial in a new session of the "
                              "patient's (default: today's session goes on), e.g. the retest "
                              "of a test-retest pair recorded the same day")
    run_cmd.add_argument("--as-proposed", action="store_true",
                         help="with --code: take the assistance, speed and tolerance the "
                              "console proposed after the patient's last trial")
    run_cmd.add_argument("--engine", choices=("auto", "compiled", "python"), default="auto",
                         help="auto (default) or compiled: the tick's kernels compiled; "
                              "python: the same kernels interpreted (the reference: the same "
                              "samples, slower)")
    from device.sim.plant import PLANTS

    run_cmd.add_argument("--plant", choices=PLANTS, default="realistic",
                         help="the simulated robot: realistic (default), its own masses, "
                              "friction, stiffness, drive gain and a 2 ms drive delay drawn "
                              "by --robot-seed around the controller's model, the same for "
                              "every trial; ideal: the model itself")
    run_cmd.add_argument("--robot-seed", type=int, default=0, metavar="N",
                         help="which realistic robot the simulator is (default 0, the "
                              "console's): its parameters are drawn by N, whatever --seed")
    run_cmd.add_argument("--learned-model", metavar="NAME",
                         help="run the computed-torque PID on this learned model, a file "
                              "NAME.json in the data folder's models/ (`rehab learn train` "
                              "writes there), checked as the Parameters tab's Build checks it")
    run_cmd.add_argument("--force-estimate", metavar="NAME",
                         help="the assistance judges the patient's force estimated from EMG "
                              "by this approved EMG model (models/emg/NAME.json, `rehab emg "
                              "model --for-assistance --save NAME`) instead of the force "
                              "sensor's; the EMG is a synthetic subject's, made from the "
                              "virtual patient's torques as the trial runs")
    run_cmd.add_argument("--emg-subject", type=int, default=1, metavar="N",
                         help="with --force-estimate: which synthetic subject's muscles and "
                              "electrodes make the EMG (1-99, default 1)")
    run_cmd.set_defaults(func=cmd_run)


def cmd_run(args: argparse.Namespace) -> int:
    """Simulate a whole trial headless, write its file and print its metrics."""
    from app.games.figures import game_line
    from app.reports.metrics_table import format_metrics
    from app.trials.registered import registered_trial

    params = trial_from_args(args)
    if args.seed is not None and args.seed < 0:
        raise CommandError(f"--seed {args.seed}: give a whole number from 0, or leave it out "
                           "for a new seed")
    if args.robot_seed < 0:
        raise CommandError(f"--robot-seed {args.robot_seed}: give a whole number from 0 "
                           "(0 is the console's simulated robot)")
    from device.sim.seeds import draw_seed

    args.seed = draw_seed() if args.seed is None else args.seed
    model = None
    if args.learned_model:
        if args.controller == "smc":
            # the model stands in for M, C and f of the computed-torque PID; sliding mode
            # has no place for it, and running ctpid instead would not be what was asked
            raise CommandError("--learned-model runs the computed-torque PID with the model "
                               "in place of M, C and f: leave out --controller smc")
        params, model = _with_learned_model(params, args.learned_model, data_dir_for(args))
    feed, options = None, {}
    if args.force_estimate is not None:
        params, feed = _with_force_estimate(params, args)
        if args.patient != "passive":
            # the synthetic subject pushes along the path as in the trials it was recorded in
            options["patient_options"] = {"drive_N": feed.subject.drive_N}
    elif args.emg_subject != 1:
        raise CommandError("--emg-subject needs --force-estimate: the subject's EMG feeds the "
                           "estimate")
    if args.as_proposed and not args.code:
        raise CommandError("--as-proposed needs --code: a proposal belongs to a patient")
    if args.new_session and not args.code:
        raise CommandError("--new-session needs --code: a session belongs to a patient")
    run = {"subject_code": args.code or "SIM", "patient": args.patient, "seed": args.seed,
           "engine": args.engine, "plant": args.plant, "robot_seed": args.robot_seed,
           "model": model, "feed": feed, **options}
    begun = None
    if args.code:
        if args.output:
            raise CommandError("--output cannot be used with --code: a registered trial is "
                               "written to the patient's folder in the data folder")
        registry = registry_for(args)
        patient = registry.patient(args.code)
        params = params.replace(**patient.trial_overrides())
        if args.as_proposed:
            params = _as_proposed(registry, args.code, params)
        # the row and the file begin and end together: a refused or failed run leaves no
        # trial 'recording' without its file (app.trials.registered)
        with registered_trial(registry, args.code, params,
                              backend=f"simulator ({args.patient}, seed {args.seed})",
                              patient_kind=args.patient,
                              session_number=next_session(registry, args.code)
                              if args.new_session else None) as begun:
            path = begun.path
            trial, analysis, problem = _simulate(params, path, run)
    elif args.output:
        path = output_path(args, args.output)
        trial, analysis, problem = _simulate(params, path, run)
    else:
        # without --output or --code nothing is kept: trying `rehab run` from a fresh clone
        # once made the data folder (and trials/simulated/), files no command lists
        with tempfile.TemporaryDirectory(prefix="rehab-run-") as scratch:
            trial, analysis, problem = _simulate(params, Path(scratch) / "trial.h5", run)
        path = None
    if begun is not None:
        from app.trials.finalize import finalize_trial

        # analysed once, by the run: the registry takes its figures
        done = finalize_trial(registry, begun.trial_id, trial.status, analysis=analysis)
        print(f"Registered as patient {args.code}, session {begun.session_number}, "
              f"trial {begun.trial_number} (id {begun.trial_id})")
        if done.proposal is not None:
            print(f"Proposed for the next trial: {done.proposal.reason}")
        _to_the_trial_store(registry)
    loaded = f"; its kernels loaded in {trial.load_s:.2f} s first" if trial.load_s else ""
    print(f"Trial {trial.status}: {trial.simulated_s:.1f} s simulated in "
          f"{trial.elapsed_s:.2f} s ({trial.speed_vs_real_time:.0f}× real time, "
          f"{trial.engine} engine{loaded}), {args.patient} virtual patient, seed {args.seed}, "
          f"{args.plant} plant, {params.assist} assistance")
    print(f"File: {path}" if path else
          "File: not kept (--output FILE keeps it; --code CODE registers it for a patient)")
    if analysis is None:
        print(f"No figures: {problem}")
    else:
        print(format_metrics(analysis.metrics))
        game = game_line(params.to_dict(), analysis.to_metrics())
        if game:
            print(f"  {game}")
        for note in analysis.notes:
            print(f"  note: {note}")
    for event in trial.events:
        if event["kind"] == "fault":
            print(f"  fault at {event['time_s']:.3f} s: {event['message']}")
    return EXIT_OK


def _to_the_trial_store(registry) -> None:
    """The station's finished trials copied into its shared trial store, when the setting
    trial_store names one (app.records.trialstore); what could not be, said in a line each
    (the trials wait in the data folder: the next run or the window copies them)."""
    from app.records.settings import load_settings
    from app.records.trialstore import store_pending

    store = load_settings().trial_store
    if not store:
        return
    stored = store_pending(registry, store)
    if stored.trials:
        print(f"Copied to the trial store {store}: {len(stored.trials)} trial file(s), each "
              "checked against its checksum")
    for line in stored.problems:
        print(f"Not in the trial store: {line}", file=sys.stderr)


def _simulate(params, path, run: dict):
    """simulate_to_file with a progress bar on a terminal."""
    from app.trials.headless import simulate_to_file

    bar = progress_bar(f"simulating {params.repetitions} × {params.duration_s:g} s")
    try:
        # straight into the file, block by block: memory stays flat in the trial's length
        return simulate_to_file(params, path, progress=bar.update if bar else None, **run)
    finally:
        if bar:
            bar.done()


def _with_learned_model(params, name: str, data_dir):
    """`params` on the computed-torque PID with the learned model `name` (its hash set),
    and the model, read from the data folder's models/ and checked (app.learning.library);
    ModelFileError (one line, its reason) otherwise."""
    from app.learning.library import inverse_dynamics, robot_model
    from core.trial import MODEL_NAME

    if not MODEL_NAME.fullmatch(name):
        raise CommandError(f"--learned-model {name!r} is not a model name: letters, digits, "
                           ". _ - (the stem of a file in the data folder's models/)")
    checked = robot_model(data_dir.models_dir, name)
    params = params.replace(controller="ctpid", learned_model=name,
                            learned_model_sha256=checked.content_sha256)
    return params, inverse_dynamics(checked)


def _with_force_estimate(params, args):
    """`params` naming the approved EMG model (its hash set), and the feed that makes the
    synthetic subject's EMG and the estimate from it (app.emg.feed)."""
    from app.emg.feed import MAX_SECONDS, SyntheticEmgFeed
    from app.emg.modelfile import emg_model
    from app.emg.subjects import Subject
    from core.trial import MODEL_NAME
    from device.loop.pipeline import PERIOD_S

    name = args.force_estimate
    if not MODEL_NAME.fullmatch(name):
        raise CommandError(f"--force-estimate {name!r} is not a model name: letters, digits, "
                           ". _ - (the stem of a file in the data folder's models/emg/)")
    if not 1 <= args.emg_subject <= 99:
        raise CommandError(f"--emg-subject {args.emg_subject}: give a number from 1 to 99")
    if params.repetitions * params.duration_s > MAX_SECONDS:
        raise CommandError(f"--force-estimate keeps the trial's EMG: give at most "
                           f"{MAX_SECONDS:g} s of exercise (this trial has "
                           f"{params.repetitions * params.duration_s:g} s)")
    checked = emg_model(data_dir_for(args).models_dir, name)
    subject = Subject.drawn(args.emg_subject, patient=args.patient, muscles=checked.muscles)
    refused = checked.refusal(params, SyntheticEmgFeed.latency_of(subject))
    if refused:
        raise CommandError(refused)
    params = params.replace(force_estimate=name, force_estimate_sha256=checked.content_sha256)
    return params, SyntheticEmgFeed(subject, checked, params.arm(), period_s=PERIOD_S,
                                    seed=args.seed)


def _as_proposed(registry, code: str, params):
    """`params` with the pending proposal after the patient's last trial applied."""
    from app.trials.progression import Proposal

    pending = [p for p in registry.proposals_for_patient(code) if p.decision == "pending"]
    if not pending:
        raise CommandError(f"patient {code} has no proposal waiting: run a trial first, or "
                           "leave out --as-proposed")
    proposal = Proposal.from_dict(pending[-1].proposal)
    print(f"As proposed: {proposal.reason}")
    return proposal.applied_to(params)
