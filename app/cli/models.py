"""`rehab models`: the model files that may drive the robot, between installations.

Learned robot models (`models/NAME.json`, app.learning.library) and approved EMG models
(`models/emg/NAME.json`, app.emg.modelfile) carry this installation's signature
(app.records.signing): an edited file is refused, and so is one from another console.
`export` writes a checked model without the signature, for another installation; `import`
checks a file as the console checks its own (its format, its content hash, its weights, an
EMG model's approval under the console's rule) and writes it into this data folder signed
here, never over a model of the same name. `list` says which models are usable here.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from app.cli.common import EXIT_OK, CommandError, absolute, subcommands
from core.trial import MODEL_NAME

KINDS = ("learned", "emg")


def add_models_command(commands) -> None:
    models = commands.add_parser(
        "models", help="learned and EMG models: list, export, import (signed here)",
        description="The model files a trial may run on. Each is signed by this "
                    "installation; `import` brings in a model from another console, "
                    "checked, and signs it; `export` writes one for another console.")
    actions = subcommands(models)
    p = actions.add_parser("list", help="the data folder's models and whether each is usable")
    p.set_defaults(func=cmd_list)
    p = actions.add_parser("export", help="write a model for another installation",
                           description="Write a model of this data folder, checked, without "
                                       "this installation's signature, for `rehab models "
                                       "import` on another console.")
    p.add_argument("name", help="the model's name (its file's stem)")
    p.add_argument("--emg", action="store_true", help="an EMG model (models/emg/)")
    p.add_argument("--output", required=True, help="the file to write (never replaced)")
    p.set_defaults(func=cmd_export)
    p = actions.add_parser("import", help="check a model from elsewhere and sign it here",
                           description="Check a model file (a learned model or an approved "
                                       "EMG model, by its format) as the console checks its "
                                       "own, and write it into the data folder's models, "
                                       "signed by this installation.")
    p.add_argument("file", help="the model file (JSON)")
    p.add_argument("--name", help="its name here (default: the file's stem)")
    p.set_defaults(func=cmd_import)


def _folder(args, emg: bool) -> Path:
    from app.cli.common import data_dir_for

    models = data_dir_for(args).models_dir
    return models / "emg" if emg else models


def _read(path: Path, emg: bool, signed: bool):
    if emg:
        from app.emg.modelfile import read_emg_model

        return read_emg_model(path, signed=signed)
    from app.learning.modelfile import read_model

    return read_model(path, signed=signed)


def cmd_list(args: argparse.Namespace) -> int:
    from app.learning.modelfile import ModelFileError

    any_model = False
    for emg in (False, True):
        folder = _folder(args, emg)
        names = sorted(p.stem for p in folder.glob("*.json")) if folder.is_dir() else []
        for name in names:
            any_model = True
            try:
                if emg:
                    _read(folder / f"{name}.json", emg, signed=True)
                    state = "usable"
                else:
                    # what the Parameters tab and `rehab run --learned-model` check: a
                    # signed, sound file is not yet a model of the robot (a pendulum's);
                    # on a real robot only a model of that robot's trials (by its name)
                    from app.learning.library import robot_model, robot_of

                    robot = robot_of(robot_model(folder, name))
                    state = "usable on the simulator" + (f" and on robot {robot}" if robot
                                                         else "")
            except ModelFileError as exc:
                state = f"refused: {exc.reason} ({exc.problem})"
            print(f"{'emg' if emg else 'learned':<8} {name:<32} {state}")
    if not any_model:
        print("no models in this data folder")
    return EXIT_OK


def cmd_export(args: argparse.Namespace) -> int:
    from app.records import signing

    if not MODEL_NAME.fullmatch(args.name):
        raise CommandError(f"{args.name!r} is not a model name: letters, digits, . _ - "
                           "(at most 100)")
    source = _folder(args, args.emg) / f"{args.name}.json"
    _read(source, args.emg, signed=True)  # only a model usable here leaves
    document = signing.unsigned(json.loads(source.read_text(encoding="utf-8")))
    output = absolute(args.output)
    _write_new(output, document)
    print(f"exported {args.name} to {output}; on the other console: rehab models import "
          f"{output.name}")
    return EXIT_OK


def cmd_import(args: argparse.Namespace) -> int:
    from app.emg.modelfile import FORMAT as EMG_FORMAT
    from app.learning.modelfile import FORMAT as LEARNED_FORMAT, ModelFileError, load_document
    from app.records import signing

    source = absolute(args.file)
    if not source.exists():
        raise CommandError(f"{source} does not exist; check the path of the model file")
    if not source.is_file():
        raise CommandError(f"{source} is not a file; give the model file to import")
    name = args.name if args.name is not None else source.stem
    if not MODEL_NAME.fullmatch(name):
        raise CommandError(f"{name!r} is not a model name: letters, digits, . _ - (at most "
                           "100); give one with --name")
    document = load_document(source, "rehab models export")
    kind = document.get("format") if isinstance(document, dict) else None
    if kind not in (LEARNED_FORMAT, EMG_FORMAT):
        raise ModelFileError(source, "format", "is neither a learned model nor an EMG model "
                             "of this console", "Give a file written by `rehab models "
                             "export`.")
    emg = kind == EMG_FORMAT
    checked = _read(source, emg, signed=False)  # everything but the signature
    from app.cli.common import data_dir_for

    data_dir = data_dir_for(args)
    folder = data_dir.ensure("models", "emg") if emg else data_dir.ensure("models")
    target = folder / f"{name}.json"
    _write_new(target, signing.sign(document), owned=True)
    print(f"imported {'EMG model' if emg else 'learned model'} {name} (content SHA-256 "
          f"{checked.content_sha256[:12]}…), signed by this installation: {target}")
    return EXIT_OK


def _write_new(path: Path, document: dict, *, owned: bool = False) -> None:
    """Write the document as a new file, whole or not at all, never over an existing one,
    readable by its user only (app.records.safewrite); `owned`: a file the data folder owns
    (an imported model in models/), else a user's output, never inside a data folder."""
    from app.records.safewrite import OutputRefused, write_text

    try:
        write_text(path, json.dumps(document, indent=1, allow_nan=False) + "\n", owned=owned)
    except OutputRefused as exc:
        raise CommandError(str(exc)) from None
