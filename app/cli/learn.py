"""`rehab learn`: learned inverse dynamics (thesis sections 2.5 and 4.4). `pendulum` writes
the sliding inverted pendulum's data (eq. 2.36–2.39), `train` fits a feed-forward network,
a GRU or a Deep Lagrangian Network to a dynamics data file, `evaluate` prints a model's RMSE
per generalised force on any file in that format (docs/data-format.md, "Dynamics data").
`robot-data` turns recorded trial files into robot data. JAX is imported only when
`train` runs."""

from __future__ import annotations

import argparse
import functools
import json
import math

from app.cli.common import (
    EXIT_OK,
    CommandError,
    absolute,
    counted,
    data_dir_for,
    output_path,
    progress_bar,
    subcommands,
)
from core.learning.pendulum import MAX_BASE_SPEED_M_S

MODELS = ("fnn", "rnn", "delan")
MAX_EPOCHS = 10_000
"""The most epochs a training may be given: 100 by default, and early stopping ends most
runs before; 10,000 of the thesis's data are about a day of a core, 1e8 were accepted and
would have run for years."""
MAX_LEARNING_RATE = 1.0
"""Adam's first step may be at most this: the defaults are 3e-3 and 1e-2, and a step above 1
moves every weight past its own scale (1e9 was accepted, and saved a model whose
cross-validation RMSE was 1e8 into the models the Parameters tab offers)."""
DEFAULT_MASS_SCALE = 3.0
MASS_SCALE_RANGE = (1e-3, 1e3)
"""The DeLaN's Cholesky unit, √ of a mass matrix's entries (kg, kg·m²): from a gram's
worth to a thousand tonnes'."""


def add_learn_commands(commands) -> None:
    learn = commands.add_parser(
        "learn", help="learned inverse dynamics: pendulum and robot data, train, evaluate",
        description="Learned inverse dynamics (thesis sections 2.5, 4.4): make the "
                    "sliding inverted pendulum's data, train FNN, RNN (GRU) or DeLaN "
                    "models on a dynamics data file, evaluate them on any such file.",
    )
    actions = subcommands(learn)

    pendulum = actions.add_parser(
        "pendulum", help="write the sliding inverted pendulum's data (eq. 2.36–2.39)",
        description="Write the thesis's pendulum data: the rod driven at constant speeds "
                    "from −45° to 45°, 101 samples a cycle; by default 1,000 cycles at "
                    "1 … 10 rad/s (101,000 samples), the 5 rad/s cycle marked held out.")
    pendulum.add_argument("--output", required=True, help="HDF5 file to write (an existing "
                                                          "file is kept unless --overwrite)")
    _overwrite_option(pendulum)
    pendulum.add_argument("--speeds", type=_positive, nargs="+", metavar="RAD_S",
                          help="the rod's speeds, one cycle each (default: the thesis's "
                               "1,000 speeds, 1 to 10); each must keep the base under "
                               f"{MAX_BASE_SPEED_M_S:g} m/s, or the line refusing it names "
                               "the speeds that do; none is held out unless --held-out "
                               "names it")
    pendulum.add_argument("--held-out", type=_positive, metavar="RAD_S",
                          help="the speed of the cycle kept out of training (default 5 "
                               "with the thesis's speeds)")
    pendulum.set_defaults(func=cmd_pendulum)

    robot = actions.add_parser(
        "robot-data", help="recorded trials as robot dynamics data (thesis section 4.3)",
        description="Write the exercise samples of trial files as a dynamics data file: "
                    "joint angles, rates, accelerations and the applied torque, one cycle "
                    "per trial.")
    robot.add_argument("--trials", nargs="+", required=True, help="trial files (HDF5)")
    robot.add_argument("--output", required=True, help="dynamics data file to write (an "
                                                       "existing file is kept unless "
                                                       "--overwrite)")
    _overwrite_option(robot)
    # estimated by default: a model of the reference's accelerations (the thesis's choice)
    # tracked 19 / 60 mm in the loop where the analytic model tracks 7 / 4 (docs/validation.md)
    robot.add_argument("--acceleration", choices=("desired", "estimated"), default="estimated",
                       help="estimated (default): the loop's estimates, what a model for the "
                            "robot's controller must learn; desired: the reference's, as the "
                            "thesis trained on (section 4.3), which breaks a model in the loop")
    robot.add_argument("--without-hand-force", action="store_true",
                       help="take the hand force's torque J_Rᵀ F out of the torque "
                            "(section 4.4.1)")
    robot.add_argument("--system", help="the system's name (default: rehab-robot-<backend>; "
                                           "another rehab-robot-… name is refused)")
    robot.set_defaults(func=cmd_robot_data)

    train = actions.add_parser(
        "train", help="train a model on a dynamics data file",
        description="Train a model on a dynamics data file (its held-out cycles left out) "
                    "with Adam, early stopping and k-fold cross-validation over its "
                    "cycles, seeds fixed; write the model file.")
    train.add_argument("--model", choices=MODELS, required=True,
                       help="fnn: feed-forward network; rnn: GRU; delan: Deep Lagrangian "
                            "Network with a learned dissipative term")
    train.add_argument("--data", required=True, help="dynamics data file (HDF5)")
    train.add_argument("--output", help="model file to write (JSON; default: the data "
                                        "folder's models/NAME.json, where the Parameters "
                                        "tab offers a robot model as 'CT-PID (learned: "
                                        "NAME)'); an existing file is kept unless "
                                        "--overwrite")
    _overwrite_option(train)
    train.add_argument("--hidden", type=_layers, metavar="N[,N…]",
                       help="hidden layer sizes (default fnn 24,24; rnn 12; delan 16,16)")
    train.add_argument("--epochs", type=_whole, default=100,
                       help=f"at most (default 100, up to {MAX_EPOCHS:,})")
    train.add_argument("--folds", type=_whole, default=5,
                       help="k of k-fold cross-validation (default 5; 1: one validation "
                            "split of 20 %% of the cycles)")
    train.add_argument("--batch-size", type=_whole,
                       help="samples a step (default fnn 512, delan 128; rnn: 16 "
                            "sequences)")
    train.add_argument("--learning-rate", type=_positive,
                       help="Adam's first step size, decayed to 1e-4 along a cosine "
                            "(default fnn and rnn 3e-3, delan 1e-2; at most "
                            f"{MAX_LEARNING_RATE:g})")
    train.add_argument("--patience", type=_whole, default=20,
                       help="epochs without a better validation error before stopping, "
                            "counted from the middle of --epochs, once the rate has come "
                            "down to half (default 20)")
    train.add_argument("--seed", type=int, default=0, help="default 0")
    train.add_argument("--cyclic", nargs="*", metavar="COORDINATE",
                       help="coordinates the dynamics does not depend on, left out of the "
                            "models' positions (default: those the file names; none: give "
                            "the option alone)")
    train.add_argument("--mass-scale", type=_positive,
                       help="delan only: unit of its Cholesky factor, of the order of √ of "
                            "the mass matrix's entries, "
                            f"{MASS_SCALE_RANGE[0]:g} to {MASS_SCALE_RANGE[1]:g} (default "
                            f"{DEFAULT_MASS_SCALE:g}, for the pendulum; 0.5 for the robot)")
    train.add_argument("--name", help="the model's name (default: the output file's stem; "
                                      "without --output, MODEL-DATA from the two files)")
    train.set_defaults(func=cmd_train)

    evaluate = actions.add_parser(
        "evaluate", help="a model's RMSE per generalised force on a dynamics data file",
        description="Evaluate a model file on a dynamics data file: RMSE of each "
                    "generalised force, on the file's held-out cycles if it marks some, "
                    "else on all of it.")
    evaluate.add_argument("--model", required=True, help="model file (JSON)")
    evaluate.add_argument("--data", required=True, help="dynamics data file (HDF5)")
    evaluate.add_argument("--all-cycles", action="store_true",
                          help="every cycle, the held-out ones and the trained ones")
    evaluate.add_argument("--json", action="store_true",
                          help='one JSON object: {"rmse": {force: value}, "parameters": N}')
    evaluate.set_defaults(func=cmd_evaluate)

    components = actions.add_parser(
        "components", help="a DeLaN's torque components against the analytic model's",
        description="The inertial, Coriolis/centrifugal, potential and dissipative torques "
                    "a DeLaN learned, against the system's own model (the pendulum of "
                    "eq. 2.36, or the console's nominal robot), on the data file's held-out "
                    "cycles or one --cycle: RMSE per component, and the plot as a PNG "
                    "(thesis Figs. 2.16-2.18, 4.5-4.6).")
    components.add_argument("--model", required=True, help="DeLaN model file (JSON)")
    components.add_argument("--data", required=True, help="dynamics data file (HDF5)")
    components.add_argument("--output", required=True, help="PNG file to write (an existing "
                                                            "file is kept unless --overwrite)")
    _overwrite_option(components)
    components.add_argument("--cycle", type=int, help="this cycle only (a trial, a sweep)")
    components.set_defaults(func=cmd_components)


def cmd_pendulum(args: argparse.Namespace) -> int:
    from app.learning.workflow import make_pendulum_file
    from core.learning.pendulum import HELD_OUT_SPEED_RAD_S, THESIS_SPEEDS_RAD_S, speed_refusal

    held = args.held_out
    for speed in args.speeds or ():
        refused = speed_refusal(speed)
        if refused:
            raise CommandError(f"--speeds {speed:g}: {refused}")
    if held is None and args.speeds is None:
        held = HELD_OUT_SPEED_RAD_S
    if held is not None and args.speeds is None and not _one_of(held, THESIS_SPEEDS_RAD_S):
        raise CommandError(f"--held-out {held:g} is none of the thesis's speeds (1 + k/111 "
                           "rad/s, k = 0 … 999, such as 5): name one, or give --speeds "
                           "with it among them")
    if held is not None and args.speeds is not None and not _one_of(held, args.speeds):
        raise CommandError(f"--held-out {held:g} is none of --speeds: the held-out cycle "
                           "must be one of the speeds")
    output = output_path(args, args.output, overwrite=args.overwrite)
    data = make_pendulum_file(output, args.speeds, held, overwrite=args.overwrite)
    cycles = len(data.description["cycle_speeds_rad_s"])
    held_text = f", cycle at {held:g} rad/s held out" if held is not None else ""
    print(f"{output}: {len(data):,} samples, {counted(cycles, 'cycle')}{held_text}")
    return EXIT_OK


def _one_of(speed: float, speeds) -> bool:
    """Whether `speed` (rad/s) is one of `speeds`, as typed to the printed digits."""
    return any(math.isclose(speed, s, rel_tol=0, abs_tol=1e-9) for s in speeds)


def cmd_robot_data(args: argparse.Namespace) -> int:
    from app.learning.dataset import write_dataset
    from app.learning.workflow import robot_dataset

    trials = [absolute(p) for p in args.trials]
    output = output_path(args, args.output, overwrite=args.overwrite, inputs=trials)
    data = robot_dataset(trials, acceleration=args.acceleration,
                         without_hand_force=args.without_hand_force, system=args.system)
    write_dataset(output, data, overwrite=args.overwrite)
    print(f"{output}: {len(data):,} samples, {counted(len(args.trials), 'trial')}, "
          f"system {data.system}")
    return EXIT_OK


def cmd_train(args: argparse.Namespace) -> int:
    from app.learning.workflow import train_file

    if args.epochs > MAX_EPOCHS:
        raise CommandError(f"--epochs {args.epochs}: give at most {MAX_EPOCHS:,} (default "
                           "100; early stopping ends most runs before): so many would train "
                           "for days")
    if args.learning_rate is not None and args.learning_rate > MAX_LEARNING_RATE:
        raise CommandError(f"--learning-rate {args.learning_rate:g}: give at most "
                           f"{MAX_LEARNING_RATE:g} (default fnn and rnn 3e-3, delan 1e-2): a "
                           "larger first step throws every weight past its scale and the "
                           "training diverges")
    if args.mass_scale is not None and args.model != "delan":
        raise CommandError(f"--mass-scale is the DeLaN's (its mass matrix's unit); a "
                           f"{args.model} has none: leave it out")
    low, high = MASS_SCALE_RANGE
    if args.mass_scale is not None and not low <= args.mass_scale <= high:
        raise CommandError(f"--mass-scale {args.mass_scale:g}: give {low:g} to {high:g}, "
                           "√ of the mass matrix's entries in kg and kg·m² (3 for the "
                           "pendulum, 0.5 for the robot)")
    mass_scale = DEFAULT_MASS_SCALE if args.mass_scale is None else args.mass_scale
    options = {"epochs": args.epochs, "folds": args.folds, "batch_size": args.batch_size,
               "learning_rate": args.learning_rate, "patience": args.patience,
               "seed": args.seed, "mass_scale": mass_scale}
    if args.hidden:
        options["hidden"] = args.hidden
    data = absolute(args.data)
    name, owned, checked = args.name, args.output is None, None
    if args.output is not None:
        # checked before the training, which may take minutes, and again when written
        output = output_path(args, args.output, overwrite=args.overwrite, inputs=[data])
    else:
        from core.trial import MODEL_NAME

        name = name or f"{args.model}-{data.stem}"
        if not MODEL_NAME.fullmatch(name):
            raise CommandError(f"--name {name!r} is not a model name: letters, digits, . _ - "
                               "(at most 100), so that a trial can name it")
        if args.overwrite:
            raise CommandError("--overwrite needs --output: a model in the data folder's "
                               "models/ is never replaced (trials name it); give another "
                               "--name")
        data_dir = data_dir_for(args)
        output = data_dir.models_dir / f"{name}.json"
        # made once the data are found trainable: a refused run leaves no data folder
        checked = functools.partial(data_dir.ensure, "models")
        if output.exists():
            raise CommandError(f"{output} already exists and is kept (trials may name it); "
                               "give another --name")
    bar = progress_bar(f"training {args.model}")
    trained = train_file(data, output, args.model, cyclic=args.cyclic, name=name,
                         progress=bar.update if bar else None, overwrite=args.overwrite,
                         owned=owned, checked=checked, **options)
    if bar:
        bar.done()
    rmse = ", ".join(f"{k} {v:.4g} {trained.units[k]}"
                     for k, v in trained.cross_validation_rmse.items())
    print(f"{trained.path}: {args.model}, {counted(trained.parameters, 'parameter')}, "
          f"{counted(trained.samples, 'training sample')}, "
          f"{trained.training_seconds:.1f} s; cross-validation RMSE {rmse}")
    return EXIT_OK


def cmd_evaluate(args: argparse.Namespace) -> int:
    from app.learning.workflow import evaluate_file

    result = evaluate_file(absolute(args.model), absolute(args.data), args.all_cycles)
    if args.json:
        print(json.dumps({"rmse": result.rmse, "units": result.units,
                          "parameters": result.parameters}, ensure_ascii=False))
        return EXIT_OK
    cycles = (counted(result.cycles, "held-out cycle") if result.held_out else
              f"{counted(result.cycles, 'cycle')}, the whole file")
    print(f"{counted(result.samples, 'sample')}, {cycles}; "
          f"{counted(result.parameters, 'parameter')}")
    width = max(len(k) for k in result.rmse)
    for force, value in result.rmse.items():
        print(f"  RMSE {force:<{width}}  {value:.6g} {result.units[force]}")
    return EXIT_OK


def cmd_components(args: argparse.Namespace) -> int:
    from app.learning.components import COMPONENTS, components_file, plot_components

    model, data = absolute(args.model), absolute(args.data)
    output = output_path(args, args.output, overwrite=args.overwrite, inputs=[model, data],
                         suffixes=(".png",))
    c = components_file(model, data, cycle=args.cycle)
    rmse = c.rmse()
    print(f"{counted(c.tau.shape[0], 'sample')} of {c.system}: RMSE against the analytic "
          "model")
    heads = [f"{force} ({c.units[force]})" for force in c.forces]
    print(f"  {'component':<12}" + "".join(f"{head:>14}" for head in heads))
    for name in (*COMPONENTS, "total"):
        label = "total (data)" if name == "total" else name
        print(f"  {label:<12}" + "".join(f"{v:>14.4g}" for v in rmse[name]))
    plot_components(c, output, title=f"{model.name} on {c.system}", overwrite=args.overwrite)
    print(f"figure: {output}")
    return EXIT_OK


def _overwrite_option(parser) -> None:
    parser.add_argument("--overwrite", action="store_true",
                        help="replace the --output file if it exists (never a file the data "
                             "folder keeps: its registry, trial files, models)")


def _positive(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not math.isfinite(value) or value <= 0:
        raise argparse.ArgumentTypeError(f"{text} must be a finite number > 0")
    return value


def _whole(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"{text} must be 1 or more")
    return value


def _layers(text: str) -> tuple[int, ...]:
    try:
        sizes = tuple(int(part) for part in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not sizes such as 16,16") from None
    if not sizes or any(s < 1 or s > 4096 for s in sizes):
        raise argparse.ArgumentTypeError(f"{text}: each layer has 1 … 4096 units")
    return sizes
