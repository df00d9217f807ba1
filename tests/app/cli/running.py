"""Running `rehab` in the test's process: its exit code, what it printed and what it said."""

from __future__ import annotations

from app.cli.main import main


def run(args, capsys):
    try:
        code = main(args)
    except SystemExit as exc:  # argparse exits from inside parse_args
        code = exc.code
    out = capsys.readouterr()
    return code, out.out, out.err
