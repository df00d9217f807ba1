"""Every command's --help says what each of its arguments is (README: "Every command has
`--help`")."""

from __future__ import annotations

import argparse

from app.cli.main import build_parser


def _parsers(parser: argparse.ArgumentParser, path: str):
    yield path, parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield from _parsers(sub, f"{path} {name}")

def test_every_argument_of_every_command_has_its_help():
    """`--controller {smc,ctpid}`, `export --format`, `export --overwrite`, `emg model
    --model` and others had none: which is the default, what is replaced, what each is."""
    parser, _ = build_parser()
    bare = [f"{path} {action.option_strings or action.dest}"
            for path, sub in _parsers(parser, "rehab") for action in sub._actions
            if action.help is None and not isinstance(action, argparse._SubParsersAction)]
    assert bare == []

def test_no_help_shows_a_doubled_percent_sign():
    """`rehab emg model --help` said "the trials' %% MVC envelopes": a description is not
    %-formatted as an argument's help is."""
    parser, _ = build_parser()
    for path, sub in _parsers(parser, "rehab"):
        assert "%%" not in sub.format_help(), path
