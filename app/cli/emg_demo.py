"""`rehab emg demo`: a synthetic subject's trials with EMG and their MVC files, so a
researcher without recorded EMG can follow the README's chain (import, MVC, show, an
EMG-to-torque model for the assistance, a run with it) end to end (app.emg.subjects)."""

from __future__ import annotations

import argparse

from app.cli.common import CommandError, absolute, data_roots, output_path
from app.cli.trial_options import tolerance_rad
from app.records.safewrite import check_output_folder

MAX_DEMO_TRIALS = 10


def cmd_demo(args: argparse.Namespace) -> int:
    from app.emg.subjects import (
        DEMO_PARAMETERS,
        Subject,
        contraction_path,
        record_trial,
        write_contractions,
    )

    if not 1 <= args.subject <= 99:
        raise CommandError(f"--subject {args.subject}: give a number from 1 to 99")
    if args.bad_mvc is not None and not 0.01 <= args.bad_mvc <= 1.0:
        raise CommandError(f"--bad-mvc {args.bad_mvc}: give a share from 0.01 to 1")
    if not 1 <= args.trials <= MAX_DEMO_TRIALS:
        raise CommandError(f"--trials {args.trials}: give a number from 1 to "
                           f"{MAX_DEMO_TRIALS}")
    cone_rad = tolerance_rad(args.tolerance)
    if not args.folder.strip():
        raise CommandError("the folder is empty: give where to write")
    folder = absolute(args.folder)
    bad = {"anterior_deltoid": args.bad_mvc} if args.bad_mvc is not None else None
    subject = Subject.drawn(args.subject, bad_mvc=bad)
    # every file it will write checked first: existing files are kept, none half-made
    check_output_folder(folder, roots=data_roots(args), what="the demo folder")
    stems = ([f"synthetic_S{args.subject}"] if args.trials == 1 else
             [f"synthetic_S{args.subject}_{k + 1}" for k in range(args.trials)])
    trials = [output_path(args, str(folder / f"{stem}.h5"), what="the demo's trial")
              for stem in stems]
    for muscle in subject.muscles:
        output_path(args, str(contraction_path(folder, subject, 1, muscle)),
                    what="the demo's MVC file")
    parameters = DEMO_PARAMETERS.replace(tolerance_rad=cone_rad)
    for seed, trial in enumerate(trials):
        record_trial(trial, subject, seed=seed, parameters=parameters, engine=args.engine)
        print(f"wrote {trial}", flush=True)
    contractions = write_contractions(folder, subject, session=1)
    names = " ".join(str(t) for t in trials)
    options = " ".join(f"--contraction {m}={p}:{ch}" for m, (p, ch) in contractions.items())
    print(f"next: rehab emg mvc {names} {options}")
    print(f"then: rehab emg show {trials[0]}")
    if len(trials) > 1:
        print(f"and: rehab emg model {names} --test {trials[-1]} --for-assistance "
              f"--save s{args.subject}")
        print(f"last, if it passes: rehab run --force-estimate s{args.subject} "
              f"--tolerance {args.tolerance:g} --emg-subject {args.subject}")
    return 0
