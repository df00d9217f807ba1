"""A `RobotModel` back from the description a trial file keeps of the robot it ran
(`robot`, JSON of `dataclasses.asdict(RobotModel)`: the loop's and the headless run's
writer, device.recording.trialfile), so that a trial's analysis uses the model the trial
ran (the robot's own torque of core.control.own), not the default one.

Strict: every field the model takes must be there with a value the model accepts, and
nothing else but the fields the model derives itself (`alpha`, `constants`, which are
computed again and must agree). Anything else raises ParameterError naming the field: a
description that is not this console's model is not guessed at.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping

from core.errors import CoreError, ParameterError
from core.motor import MotorParameters
from core.robot import Friction, JointLimits, Link, RobotModel, Stiffness

_PARTS = {"friction": Friction, "stiffness": Stiffness, "limits": JointLimits}
_DERIVED = ("alpha", "constants")
"""Fields the model computes from the others (init=False): checked, not taken."""


def robot_from_record(record: Mapping) -> RobotModel:
    """The RobotModel a trial file's `robot` description (dataclasses.asdict) names;
    ParameterError when it is not one (a field missing, unknown or refused)."""
    fields = _fields(RobotModel, record, "robot")
    values = {}
    for name, value in fields.items():
        if name == "links":
            links = _sequence(value, "robot.links", 4)
            values[name] = tuple(_build(Link, link, f"robot.links[{i}]")
                                 for i, link in enumerate(links))
        elif name == "motors":
            motors = _sequence(value, "robot.motors", 2)
            values[name] = tuple(_build(MotorParameters, motor, f"robot.motors[{i}]")
                                 for i, motor in enumerate(motors))
        elif name in _PARTS:
            values[name] = _build(_PARTS[name], value, f"robot.{name}")
        else:
            values[name] = value
    robot = _made(RobotModel, values, "robot")
    for name in _DERIVED:
        if name in record and not _same(record[name], getattr(robot, name)):
            raise ParameterError(f"robot.{name}", record[name],
                                 "what the robot's other fields give",
                                 "the description does not hold together")
    return robot


def _fields(kind, record, where: str) -> dict:
    if not isinstance(record, Mapping):
        raise ParameterError(where, type(record).__name__, "a mapping of its fields")
    given = {f.name for f in dataclasses.fields(kind) if f.init}
    unknown = sorted(set(record) - given - set(_DERIVED if kind is RobotModel else ()))
    if unknown:
        raise ParameterError(f"{where}.{unknown[0]}", record[unknown[0]],
                             f"one of {kind.__name__}'s fields")
    missing = sorted(given - set(record))
    if missing:
        raise ParameterError(f"{where}.{missing[0]}", None, "a value (it is missing)")
    return {name: record[name] for name in given}


def _build(kind, record, where: str):
    values = _fields(kind, record, where)
    values = {name: tuple(value) if isinstance(value, list) else value
              for name, value in values.items()}
    return _made(kind, values, where)


def _made(kind, values: dict, where: str):
    try:
        return kind(**values)
    except CoreError:
        raise
    except (TypeError, ValueError) as exc:
        raise ParameterError(where, values, f"a {kind.__name__}", str(exc)) from None


def _sequence(value, where: str, length: int) -> list:
    if not isinstance(value, list | tuple) or len(value) != length:
        raise ParameterError(where, value, f"a list of {length}")
    return list(value)


def _same(stored, derived) -> bool:
    """A derived field as stored against the model's own (to the last bit but JSON's)."""
    stored, derived = list(stored), list(derived)
    return len(stored) == len(derived) and all(
        isinstance(a, int | float) and math.isclose(a, b, rel_tol=1e-12, abs_tol=1e-15)
        for a, b in zip(stored, derived, strict=True))
