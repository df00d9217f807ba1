"""The `check` command as a therapist or researcher runs it."""

import pytest

from app.cli.main import main


def test_check_prints_arm_reachability_and_ranges(capsys):
    assert main(["check"]) == 0
    out = capsys.readouterr().out
    assert "Subject's arm" in out
    assert "100.0 % of the path inside the arm" in out
    assert "shoulder (ISB)" in out
    assert "Result: ready to run." in out


def test_default_command_is_check(capsys):
    assert main([]) == 0
    assert "Result: ready to run." in capsys.readouterr().out


def test_thesis_as_printed_is_refused_in_one_line_with_exit_2(capsys):
    assert main(["check", "--thesis-as-printed"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    assert "0.68 m from the shoulder; this arm reaches 0.61 m" in err[0]


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["check", "--radius", "-1"], "radius_m"),
        (["check", "--body-mass", "300"], "body_mass_kg"),
        (["check", "--tolerance", "nan"], "--tolerance = NaN is not allowed; allowed: a "
                                          "cone from 1 to 90 degrees"),
        # said in the option's own terms: "tolerance_rad = 1.74533e+07 … rad" answered
        # degrees, "assistance_level = 2" an --assistance of 200 %
        (["check", "--tolerance", "1e9"], "--tolerance = 1e+09 is not allowed; allowed: a "
                                          "cone from 1 to 90 degrees"),
        (["check", "--assistance", "200"], "--assistance = 200 is not allowed; allowed: 0 "
                                           "to 100 %"),
        (["check", "--radius", "5"], "--radius (radius_m) = 5 is not allowed"),
        (["check", "--shoulder", "5", "0.7"], "--shoulder (shoulder_m[x]) = 5 is not "
                                              "allowed"),
        (["check", "--radius", "abc"], "--radius 'abc' is not a number"),
        (["check", "--shape", "square"], "invalid choice"),
        (["check", "--no-such-option"], "unrecognized"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(args, needle, capsys):
    try:
        code = main(args)
    except SystemExit as exc:  # argparse errors exit from inside parse_args
        code = exc.code
    assert code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    assert needle in err[0]
    assert "Traceback" not in err[0]


@pytest.mark.parametrize(
    ("args", "command"),
    [
        (["check", "--no-such-option"], "rehab check"),
        (["progress", "P1ZTTAQ", "[--csv]"], "rehab progress"),
        (["emg", "show", "12", "--foo"], "rehab emg show"),
    ],
)
def test_an_unknown_option_points_to_its_command_s_help(args, command, capsys):
    """A misspelt option of a command (`rehab progress CODE --csvv`, or a README line's
    `[--csv]` pasted as it is) was said as "rehab: error: … (see rehab --help)", whose
    help lists the commands, not the options: it names the command and its help."""
    with pytest.raises(SystemExit) as exit_:
        main(args)
    assert exit_.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    assert err[0].startswith(f"{command}: error: unrecognized arguments: {args[-1]}")
    assert err[0].endswith(f"(see {command} --help)")
