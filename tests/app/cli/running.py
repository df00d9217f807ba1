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


def status_names_the_unsealed_row(capsys, registry: str = "") -> None:
    """`rehab db status` on a registry whose patients row 1 no longer matches its seal:
    exit 2, the seals DAMAGED, and the row named in one line of error about the registry
    (`registry`: how that line names it, as far as given)."""
    code, out, err = run(["db", "status"], capsys)
    assert code == 2
    assert "seals: DAMAGED (below)" in out
    assert err.startswith(f"rehab db status: error: the registry {registry}")
    assert "patients row 1 does not match its seal" in err
    assert err.count("\n") == 1
