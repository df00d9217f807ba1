"""The options that define a trial, shared by `rehab check` and `rehab run`.

Lengths in metres; angles in degrees as a therapist reads them; the defaults are
the thesis's experiment with the shoulder as we read it (core.trial.THESIS_SUBJECT).
"""

from __future__ import annotations

import argparse
import math

from core.errors import ParameterError
from core.trajectory import NEGLECT_SIDES, SHAPES, TIMINGS
from core.trial import (
    ASSIST_MODES,
    CONTROLLERS,
    GAMES,
    SIDES,
    THESIS_AS_PRINTED,
    THESIS_SUBJECT,
    TOLERANCE_RANGE_RAD,
    TrialParameters,
)

OPTION_OF_FIELD = {
    "shape": "--shape", "centre_m": "--centre", "radius_m": "--radius",
    "duration_s": "--duration", "repetitions": "--repetitions", "timing": "--timing",
    "n_targets": "--targets", "body_mass_kg": "--body-mass", "upper_arm_m": "--upper-arm",
    "forearm_m": "--forearm", "shoulder_m": "--shoulder", "side": "--side",
    "tolerance_rad": "--tolerance", "controller": "--controller", "assist": "--assist",
    "assistance_level": "--assistance", "gains": "--gains",
    "game": "--game", "target_radius_m": "--target-radius",
    "time_allowed_s": "--time-allowed", "n_distractors": "--distractors",
    "channel_half_width_m": "--channel-width", "neglect_side": "--neglect-side",
}
"""The option each of the trial's fields is given by: a refusal names it, as typed."""


def add_trial_options(parser: argparse.ArgumentParser) -> None:
    """Options that define a trial. Lengths in metres; angles in degrees as a therapist
    reads them; defaults are the thesis's experiment with the shoulder as we read it."""
    d = THESIS_SUBJECT
    group = parser.add_argument_group("trial (lengths in m, angles in degrees)")
    group.add_argument("--shape", "--trajectory", choices=SHAPES, default=d.shape,
                       help="exercise path (default d)")
    group.add_argument("--centre", nargs=2, type=float, metavar=("X", "Y"), default=d.centre_m,
                       help="D: centre of its straight line; circle/targets/figure8: centre; "
                            "reach: start point (default -0.30 0.30)")
    group.add_argument("--radius", type=float, default=d.radius_m,
                       help="radius; for a reach, half its length (default 0.10)")
    group.add_argument("--duration", type=float, default=d.duration_s,
                       help="seconds per traversal (default 4)")
    group.add_argument("--repetitions", type=int, default=d.repetitions,
                       help="traversals (default 5)")
    group.add_argument("--timing", choices=TIMINGS, default=d.timing,
                       help="constant speed as in the thesis, or minimum jerk per segment")
    group.add_argument("--counter-clockwise", action="store_true", help="reverse the direction")
    group.add_argument("--targets", type=int, default=d.n_targets, dest="n_targets",
                       help="number of targets for --shape targets (default 8)")
    group.add_argument("--shoulder", nargs=2, type=float, metavar=("X", "Y"),
                       default=d.shoulder_m, help="subject's shoulder (default -0.12 0.73)")
    group.add_argument("--body-mass", type=float, default=d.body_mass_kg,
                       help="body mass in kg (default 91)")
    group.add_argument("--upper-arm", type=float, default=d.upper_arm_m,
                       help="shoulder to elbow in m (default 0.3048)")
    group.add_argument("--forearm", type=float, default=d.forearm_m,
                       help="elbow to wrist in m (default 0.3048)")
    group.add_argument("--side", choices=SIDES, default=d.side, help="arm in use")
    group.add_argument("--tolerance", type=float, default=math.degrees(d.tolerance_rad),
                       help="directional tolerance in degrees (default 20)")
    group.add_argument("--controller", choices=CONTROLLERS, default=None,
                       help="smc (default): sliding mode; ctpid: computed-torque PID (what "
                            "--learned-model runs)")
    group.add_argument("--assist", choices=ASSIST_MODES, default="as-needed",
                       help="as-needed (default): a compliant channel whose reference moves "
                            "with the patient, help along the path the patient earns back; "
                            "thesis: the tracking controller on the clock with the thesis's "
                            "reduce-only cut (Fig. 3.6 as printed); transparent: no help, "
                            "the robot compensates its own inertia and friction (its level "
                            "is always 0)")
    group.add_argument("--assistance", type=float, default=None,
                       help="assistance level, 0-100 %% (default 100): as-needed, the help "
                            "along the path; thesis, the share of the subject's effort the "
                            "robot gives way to; transparent: none, leave it out")
    group.add_argument("--gains", default="", metavar="CHANGES",
                       help="changes to the controller's, the guidance's and the "
                            "transparent mode's gains, e.g. "
                            "\"smc.lambda_1_s=25; guidance.delay_s=0.5\" (rehab gains lists "
                            "them); saved with the trial")
    group.add_argument("--game", choices=[g for g in GAMES if g], default=d.game or None,
                       help="play the exercise as a game: path (keep the hand in a channel "
                            "round the path) or reach (hit the targets of shape targets or "
                            "reach in time); none by default")
    group.add_argument("--target-radius", type=float, default=d.target_radius_m,
                       help="reach game: target radius, m (default %(default)s)")
    group.add_argument("--time-allowed", type=float, default=d.time_allowed_s,
                       help="reach game: time to hit a target once it appears, s (default "
                            "%(default)s; at most the time between two targets)")
    group.add_argument("--distractors", type=int, default=d.n_distractors,
                       help="reach game: discs to avoid between the targets (default 0)")
    group.add_argument("--channel-width", type=float, default=d.channel_half_width_m,
                       help="path game: the channel's half-width either side of the path, m "
                            "(default %(default)s)")
    group.add_argument("--neglect-side", choices=[s for s in NEGLECT_SIDES if s], default=None,
                       help="turn a targets or reach layout toward the patient's neglected "
                            "side (the patient's left or right)")
    group.add_argument("--thesis-as-printed", action="store_true",
                       help="use section 3.6 exactly as printed (shoulder at +0.12 m: refused)")


def trial_from_args(args: argparse.Namespace) -> TrialParameters:
    """TrialParameters from parsed options; a refusal (ParameterError) names the option
    that was typed, and the field too where its value is in other units."""
    base = THESIS_AS_PRINTED if args.thesis_as_printed else THESIS_SUBJECT
    level = 100 * base.assistance_level if args.assistance is None else args.assistance
    if args.assist == "transparent" and args.assistance not in (None, 0.0):
        # the trial would run (and record) 0 whatever was asked: say so, not do it silently
        raise ParameterError("--assistance", args.assistance, "left out (or 0)",
                             "the transparent mode has no assistance level: nothing in it "
                             "acts on one")
    changes = {
        "shape": args.shape,
        "centre_m": tuple(args.centre),
        "radius_m": args.radius,
        "duration_s": args.duration,
        "repetitions": args.repetitions,
        "timing": args.timing,
        "clockwise": not args.counter_clockwise,
        "n_targets": args.n_targets,
        "body_mass_kg": args.body_mass,
        "upper_arm_m": args.upper_arm,
        "forearm_m": args.forearm,
        "side": args.side,
        "tolerance_rad": tolerance_rad(args.tolerance),
        "controller": args.controller or base.controller,
        "assistance_level": assistance_level(level),
        "assist": args.assist,
        "gains": args.gains,
        "game": args.game or "",
        "target_radius_m": args.target_radius,
        "time_allowed_s": args.time_allowed,
        "n_distractors": args.distractors,
        "channel_half_width_m": args.channel_width,
        "neglect_side": args.neglect_side or "",
    }
    if not args.thesis_as_printed:
        changes["shoulder_m"] = tuple(args.shoulder)
    try:
        return base.replace(**changes)
    except ParameterError as exc:
        # said by the option that was typed: "tolerance_rad = 1.7e+07 … rad" answered a
        # --tolerance given in degrees, "assistance_level = 2" an --assistance of 200 %
        option = OPTION_OF_FIELD.get(exc.field.split("[")[0])
        if option is None:
            raise
        raise ParameterError(f"{option} ({exc.field})", exc.value, exc.allowed,
                             exc.why) from None


def tolerance_rad(degrees: float) -> float:
    """--tolerance, given in degrees, in radians; refused in the degrees it was given when
    outside the cones a trial may have (core.trial.TOLERANCE_RANGE_RAD)."""
    lo, hi = (math.degrees(r) for r in TOLERANCE_RANGE_RAD)
    if not (math.isfinite(degrees) and lo <= degrees <= hi):
        raise ParameterError("--tolerance", float(degrees), f"a cone from {lo:g} to {hi:g} "
                             "degrees", "beyond 90° a push against the path would count "
                             "as help")
    return math.radians(degrees)


def assistance_level(percent: float) -> float:
    """--assistance, given in percent, as the fraction a trial takes; refused in percent
    when it is no level from 0 to 100 %."""
    if not (math.isfinite(percent) and 0.0 <= percent <= 100.0):
        raise ParameterError("--assistance", float(percent), "0 to 100 %",
                             "0: no help for the patient's effort, 100: full help")
    return percent / 100.0
