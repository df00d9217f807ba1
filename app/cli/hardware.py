"""`rehab hardware check FILE`: a robot's hardware settings file read and checked as Connect
reads it, and what the console would use from it, before the robot is powered.

Until now a wrong file showed at Connect, at the robot with a session waiting, or through a
`python -c` line in the bench check (docs/hardware.md). This reads the file with Connect's
own loader (device.hardware.settings) and the force sensor's calibration with Connect's own
reader (device.hardware.atical), then prints every value the backend would use and what
follows from them, through the backend's own conversions (device.hardware.quanser): the
angle of one encoder count, the volts written for the drive's rated current, where the
homing pose puts the handle (outside an exercise's area it is said, and Start waits for it,
docs/safety.md H8), the force limits the sensor allows. A refused file is one line and exit
2. Nothing is opened: no card, no sensor, no driver needed.
"""

from __future__ import annotations

import argparse
import math

from app.cli.common import EXIT_OK, absolute, subcommands


def add_hardware_command(commands) -> None:
    hardware = commands.add_parser(
        "hardware", help="the real robot's hardware settings: check a file",
        description="The real robot's hardware settings file (resources/hardware.example.toml "
                    "filled in for one robot, docs/hardware.md).")
    actions = subcommands(hardware)
    p = actions.add_parser(
        "check", help="read and check a settings file, and print what Connect would use",
        description="Read and check a hardware settings file and its force sensor's "
                    "calibration file as Connect does, and print every value the console "
                    "would use with what follows from it. Opens no card and no sensor. A "
                    "refused file is one line and exit status 2.")
    p.add_argument("file", help="the settings file (TOML)")
    p.set_defaults(func=cmd_check)


def cmd_check(args: argparse.Namespace) -> int:
    from device.hardware.atical import load_calibration
    from device.hardware.settings import load_hardware_settings

    settings = load_hardware_settings(absolute(args.file))
    sensor = settings.force_sensor
    calibration = load_calibration(sensor.calibration_file, sensor.calibration_index)
    for line in settings_lines(settings, calibration):
        print(line)
    return EXIT_OK


def settings_lines(settings, calibration) -> list[str]:
    """What `check` prints: the file's values as the backend would use them, with what
    follows from them, one line each."""
    from core.robot import RobotModel
    from device.hardware.quanser import QuanserBackend
    from device.safety.limits import FORCE_CEILING_FRACTION, SafetyLimits

    q, f = settings.quanser, settings.force_sensor
    robot = RobotModel()
    backend = QuanserBackend(settings, motors=robot.motors)  # not opened: its conversions
    motor = robot.motors[0]
    home = q.homing_joint_angles_rad
    x, y = (float(v) for v in robot.position(*home))
    spread = math.degrees(home[0] - home[1])
    volts = backend.volts_for_torque(motor.max_joint_torque_Nm, motor.max_joint_torque_Nm)
    fx, fy, fz = calibration.max_loads_SI[:3]
    planar = min(fx, fy)
    ceiling = FORCE_CEILING_FRACTION * planar
    default_limit = SafetyLimits().force_limit_N
    limit_words = (f"the default {default_limit:g} N is allowed" if default_limit <= ceiling
                   else f"the default {default_limit:g} N is NOT allowed: lower it in the "
                        "Parameters tab, or Connect is refused")
    links = robot.limit_problem(*home)
    return [
        f"{settings.source}: the hardware settings are valid.",
        f"[robot] {settings.robot.name!r}: every trial on it records this name, and a learned "
        "model runs on the robot whose trials it learned from",
        "[quanser]",
        f"  card: {q.board_type} {q.board_identifier!r}, options {q.card_options!r}",
        f"  encoders: inputs {_pair(q.encoder_channels)}, signs {_signs(q.encoder_signs)}; "
        f"{motor.counts_per_joint_rev:g} counts per joint turn ({motor.encoder_counts_per_rev} "
        f"per motor turn × the belt's {motor.gear_ratio:g}), "
        f"{math.degrees(motor.joint_angle_resolution_rad):.4f}° per count",
        f"  homing pose (the robot must stand in it at every Connect): θ_R1 "
        f"{math.degrees(home[0]):.1f}°, θ_R2 {math.degrees(home[1]):.1f}° (links "
        f"{spread:.1f}° apart), the handle at ({_cm(x)}, {_cm(y)}) cm"
        + (f"; {links}" if links else ""),
        f"  amplifiers: outputs {_pair(q.analog_output_channels)}, signs "
        f"{_signs(q.motor_signs)}, {q.amplifier_gain_A_per_V:g} A/V: the rated "
        f"{motor.max_current_A:g} A ({motor.max_joint_torque_Nm:.2f} N·m at the joint) is "
        f"{abs(volts[0]):.2f} V; never beyond ±{q.output_voltage_limit_V:g} V",
        f"  watchdog: the card switches the outputs off {q.watchdog_timeout_s * 1e3:g} ms "
        "after the loop's last word",
        "[force_sensor]",
        f"  calibration: {calibration.path}, calibration {f.calibration_index} "
        f"(sensor {calibration.serial}, {calibration.body_style}, {calibration.part_number}, "
        f"calibrated {calibration.cal_date}); rated Fx {fx:g} N, Fy {fy:g} N, Fz {fz:g} N",
        f"  force limit: at most {ceiling:g} N ({FORCE_CEILING_FRACTION:.0%} of the sensor's "
        f"{planar:g} N in the plane); {limit_words}",
        f"  inputs: {f.physical_channels} ({f.terminal_config}, ±{f.voltage_range_V:g} V) at "
        f"{f.sample_rate_Hz:g} Hz; a gauge at ±{f.saturation_V:g} V is saturated; a read "
        f"waits at most {f.read_timeout_s * 1e3:g} ms",
        f"  zero at Connect: {f.tare_samples} samples ({f.tare_samples / f.sample_rate_Hz:g} "
        f"s), refused if the force moves more than {f.tare_spread_limit_N:g} N (hands off "
        "the handle)",
        f"  mounting: the sensor's x axis {math.degrees(f.mounting_offset_rad):g}° from link "
        "l4",
    ]


def _pair(values) -> str:
    return f"{values[0]}, {values[1]}"


def _signs(values) -> str:
    return ", ".join(f"{v:+d}" for v in values)


def _cm(length_m: float) -> str:
    return f"{round(length_m * 100.0, 1):g}"
