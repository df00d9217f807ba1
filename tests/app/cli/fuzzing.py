"""The command line's fuzzer, shared by its test (tests/app/cli/test_fuzz.py) and its bench
(bench/fuzz_cli.py): a scratch world, argument lists drawn by hypothesis from every
subcommand's own options, a runner that runs each in a process of its own with a time
limit, and the judge of what a run did.

* `Scratch.make(folder)` builds the world every run sees, all inside one folder: a data
  folder with a registry, a patient, a trial, a learned and an EMG model; the kinds of
  path that broke commands before (a symbolic link loop, a 300-character name, a path
  1,500 folders deep, a named pipe, a CSV line over 131 KB, a Trigno export with a
  header only, model JSON with NaN, a string version, 200,000 levels of nesting, …); and
  HOME, the config folder, TMPDIR and the working folder, so nothing is written outside.
* `argv(draw, command, scratch)` draws one argument list for a command, reading its
  options off the parser, so a new option is fuzzed without touching this file.
* `Runner` starts one server process that imports the console once; each argument list
  runs in a child forked from it (a few milliseconds), killed when it passes the time
  limit (a hang), its exit code, stdout and stderr returned.
* `judge(run, changed)` names what is wrong with a run: a traceback (or an internal
  error, exit 70), a hang, a refusal on more or fewer than one line, a file changed that
  the argument list did not name.
"""

from __future__ import annotations

import argparse
import contextlib
import hashlib
import importlib
import io
import json
import os
import signal
import stat
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

from device.lsl.library import LOOPBACK_CONFIG

ROOT = Path(__file__).resolve().parents[3]
TIMEOUT_S = 60.0
"""A run longer than this is a hang: the slowest valid runs here (a trial, a model trained
for one epoch) take seconds."""

NUMBERS = ("", "0", "1", "2", "-1", "3.5", "1e309", "nan", "-inf", "inf", "99999999999999999999",
           "9" * 4400, "²", "١٢", "0x10", " 1", "1,5", "+1", "1e-320", "-0", "007")
TEXTS = ("abc", "P000000", "é", "\udcff", "--", "-", "%", "%s", "a\nb", "\t", "csv", "mat",
         "d", "healthy", "right", "biceps", "biceps=x.csv", "lsl:x", "trigno:127.0.0.1",
         "s1", "../s1", "m", "smc.lambda_1_s=25", "a" * 300)
SYSTEM_PATHS = ("/proc", "/proc/self/status", "/dev/null", "/dev/zero")
"""Paths outside the scratch folder a run may be given: none of them can be written to
harm (as root too); never "/" or /tmp."""
LONG_COMMANDS = {
    # what keeps a valid run short: taken last, so they win over the drawn values
    ("run",): ["--duration", "3", "--repetitions", "1"],
    ("learn", "train"): ["--epochs", "1", "--folds", "1", "--hidden", "2"],
    ("learn", "pendulum"): ["--speeds", "1", "2"],
    ("emg", "streams"): ["--wait", "0.2"],
    ("emg", "record"): ["--seconds", "0.2"],
    ("plan", "run"): ["--stop-after", "3"],
    ("assess", "run"): ["--task", "circle"],
}


@dataclass
class Scratch:
    """The world of every run (see the module's doc)."""

    folder: Path
    data: Path
    env: dict[str, str]
    paths: dict[str, str]
    patient: str
    _digests: dict = field(default_factory=dict, repr=False)

    @classmethod
    def make(cls, folder: Path) -> Scratch:
        folder = folder.absolute()
        home = folder / "home"
        for part in ("home", "config", "tmp", "cwd", "inputs", "outputs"):
            (folder / part).mkdir(parents=True, exist_ok=True)
        data = folder / "data"
        # not the suite's XLA cache either (tests/conftest.py): a fuzzed run writes nowhere
        # outside this folder
        env = {k: v for k, v in os.environ.items()
               if not k.startswith(("REHAB_", "XDG_", "JAX_")) and k not in ("HOME", "TMPDIR")}
        (folder / "lsl.cfg").write_text(LOOPBACK_CONFIG)
        env.update(HOME=str(home), TMPDIR=str(folder / "tmp"), REHAB_DATA_DIR=str(data),
                   REHAB_CONFIG_DIR=str(folder / "config"),
                   XDG_CACHE_HOME=str(Path.home() / ".cache"),  # the kernels' cache: read
                   LSLAPICFG=str(folder / "lsl.cfg"), QT_QPA_PLATFORM="offscreen",
                   PYTHONPATH=str(ROOT), OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")
        patient, paths = _populate(folder, data, env)
        return cls(folder, data, env, paths, patient)

    def snapshot(self) -> dict[str, tuple]:
        """Every file and folder of the scratch world: its kind, mode, size, content hash."""
        seen = {}
        for here, folders, files in os.walk(self.folder):
            folders[:] = [f for f in folders if f not in ("tmp",)]
            for name in (*folders, *files):
                path = os.path.join(here, name)
                try:
                    info = os.lstat(path)
                except OSError:
                    continue
                digest = ""
                if stat.S_ISREG(info.st_mode):
                    key = (path, info.st_ino, info.st_size, info.st_mtime_ns, info.st_ctime_ns)
                    digest = self._digests.get(key)
                    if digest is None:
                        digest = self._digests[key] = _digest(path, info)
                seen[path] = (stat.S_IFMT(info.st_mode), stat.S_IMODE(info.st_mode),
                              info.st_size if stat.S_ISREG(info.st_mode) else 0, digest)
        return seen


def _digest(path: str, info: os.stat_result) -> str:
    if info.st_size > 64 * 2**20:
        return f"{info.st_size}:{info.st_mtime_ns}"
    with open(path, "rb") as stream:
        return hashlib.blake2b(stream.read(), digest_size=12).hexdigest()


def _populate(folder: Path, data: Path, env: dict[str, str]) -> tuple[str, dict[str, str]]:
    """The data folder and the input files, made by the console itself where it can."""
    from app.records.datadir import DataDir
    from app.records.registry import Registry
    from app.trials.headless import simulate_to_file
    from core.trial import THESIS_SUBJECT

    registry = Registry(DataDir(data))
    patient = registry.create_patient("Ada", "Fuzz", birth_year=1950, body_mass_kg=70.0,
                                      upper_arm_m=0.30, forearm_m=0.28, side="right",
                                      shoulder_m=(-0.12, 0.73)).code
    params = THESIS_SUBJECT.replace(repetitions=1, duration_s=3.0)
    begun = registry.begin_trial(patient, params, backend="simulator (healthy)")
    simulate_to_file(params, begun.path, subject_code=patient)
    from app.trials.finalize import finalize_trial

    finalize_trial(registry, begun.trial_id)
    inputs = folder / "inputs"
    trial = inputs / "trial.h5"
    trial.write_bytes(begun.path.read_bytes())
    models = DataDir(data).ensure("models", "emg").parent  # as the console makes it: 0700
    (models / "m.json").write_text('{"format": "rehab-learned-model", "weights": NaN}')
    (models / "emg" / "s1.json").write_text('{"format": "rehab-emg-model"}')
    loop = inputs / "loop"
    with contextlib.suppress(FileExistsError):
        os.symlink(loop, loop)
    fifo = inputs / "fifo"
    if not fifo.exists():
        os.mkfifo(fifo)
    plain = inputs / "plain.csv"
    plain.write_text("time,EMG1 [V]\n" + "".join(f"{k / 1000:.3f},{k % 7 * 1e-5}\n"
                                                 for k in range(2000)))
    (inputs / "long-line.csv").write_text("time,EMG1\n0," + "1" * 140_000 + "\n")
    (inputs / "trigno-header.csv").write_text(
        "Label: EMG1 Sampling frequency: 1925.926 Unit: V Domain: Time\n\nX[s],EMG1\n")
    (inputs / "marks.csv").write_text("u_px,v_px,x_m,y_m\n0,0,0,0\n1,0,1,0\n0,1,0,1\n1,1,1,1\n")
    (inputs / "nan.json").write_text('{"format": "rehab-learned-model", "format_version": NaN}')
    (inputs / "version.json").write_text('{"format": "rehab-learned-model", '
                                         '"format_version": "1"}')
    (inputs / "deep.json").write_text("[" * 200_000 + "]" * 200_000)
    (inputs / "empty.csv").write_text("")
    long_name = inputs / ("n" * 240 + ".csv")
    long_name.write_text("time,EMG1\n0,1\n")
    paths = {
        "data": str(data), "registry": str(data / "registry.sqlite3"),
        "data trial": str(begun.path), "trial": str(trial), "model": str(models / "m.json"),
        "emg model": str(models / "emg" / "s1.json"), "loop": str(loop),
        "loop child": str(loop / "x.h5"), "fifo": str(fifo), "plain": str(plain),
        "long line": str(inputs / "long-line.csv"),
        "trigno header": str(inputs / "trigno-header.csv"),
        "marks": str(inputs / "marks.csv"), "nan json": str(inputs / "nan.json"),
        "version json": str(inputs / "version.json"), "deep json": str(inputs / "deep.json"),
        "empty": str(inputs / "empty.csv"), "long name": str(long_name),
        "300 chars": str(inputs / ("x" * 300)), "deep path": str(
            folder / "outputs" / "/".join(["a"] * 1500) / "x.h5"),
        "new file": str(folder / "outputs" / "new.h5"),
        "new png": str(folder / "outputs" / "new.png"),
        "new pdf": str(folder / "outputs" / "new.pdf"),
        "new csv": str(folder / "outputs" / "new.csv"),
        "new folder": str(folder / "outputs" / "new-folder"),
        "missing": str(folder / "missing" / "x.h5"), "inputs": str(inputs),
        "outputs": str(folder / "outputs"), "relative": "rel.h5",
        **{p: p for p in SYSTEM_PATHS},
    }
    return patient, paths


# -- drawing argument lists ------------------------------------------------------------------


def leaves(parser: argparse.ArgumentParser, path: tuple[str, ...] = ()):
    """(command path, its parser) for every runnable subcommand."""
    subs = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    if not subs and path:
        yield path, parser
    for action in subs:
        for name, sub in action.choices.items():
            yield from leaves(sub, (*path, name))


def options(parser: argparse.ArgumentParser):
    """(option string or None for a positional, its dest, how many values, its choices, the
    kind of value it takes: 'float', 'int', 'layers' or 'text', whether it is required)."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            continue
        nargs = action.nargs
        count = 0 if nargs == 0 else (nargs if isinstance(nargs, int) else 1)
        yield (action.option_strings[-1] if action.option_strings else None, action.dest,
               count, tuple(action.choices) if action.choices else (), _kind(action.type),
               action.required)


def _kind(kind) -> str:
    name = getattr(kind, "__name__", "")
    if kind is float or name in ("_positive", "finite_float"):
        return "float"
    if kind is int or name in ("_whole", "record_id"):
        return "int"
    if name == "_layers":
        return "layers"
    return "text"


FLOATS = ("0.1", "0.5", "1", "2", "3", "4", "20", "30", "0.05", "-0.12", "0.73", "-0.3")
INTS = ("1", "2", "3", "5")
PATHY = ("output", "data", "model", "folder", "marks", "reference", "video", "file",
         "contraction")


def commands() -> dict[tuple[str, ...], argparse.ArgumentParser]:
    from app.cli.main import build_parser

    parser, _ = build_parser()
    return dict(leaves(parser))


def argv(draw, command: tuple[str, ...], parser: argparse.ArgumentParser,
         scratch_paths: dict[str, str], patient: str) -> list[str]:
    """One argument list for `command`: each option present or not; each value most often
    of the kind the option takes (a number, one of its choices, a path of the scratch world,
    the patient's code), else anything: a number of the kinds that broke commands, a text,
    a path of any kind, what a shell can type."""
    from hypothesis import strategies as st

    # what a shell can pass: no NUL, and no surrogates but those of undecodable bytes
    typed = st.text(st.characters(blacklist_characters="\x00",
                                  blacklist_categories=("Cs",)), max_size=8)
    paths = st.sampled_from(sorted(scratch_paths.values()))
    anything = st.one_of(st.sampled_from(NUMBERS), st.sampled_from(TEXTS), paths,
                         st.just(patient), typed)
    fitting = {"float": st.sampled_from(FLOATS), "int": st.sampled_from(INTS),
               "layers": st.sampled_from(("2", "4,4", "0", "5000"))}
    args = list(command)
    for option, dest, count, choices, kind, required in options(parser):
        if option in ("-h", "--help") and draw(st.integers(0, 40)) != 0:
            continue  # the help ends the run before anything else: rarely
        if option is not None and not required and draw(st.integers(0, 2)) != 0:
            continue  # an option given one time in three
        if (option is None or required) and draw(st.integers(0, 9)) == 0:
            continue  # a positional or a required option left out one time in ten
        if choices:
            good = st.sampled_from(choices)
        elif kind != "text":
            good = fitting[kind]
        elif dest == "code" or dest == "codes":
            good = st.just(patient)
        elif dest in ("trial", "trials", "trial_id", "trial_ids", "test"):
            good = st.one_of(paths, st.just("1"))  # a registered trial's id, or a file
        elif any(word in dest for word in PATHY):
            good = paths
        else:
            good = anything
        pick = good if draw(st.integers(0, 6)) != 0 else anything  # anything one time in 7
        if option is not None:
            args.append(option)
        args.extend(str(draw(pick)) for _ in range(count or 0))
        if option is None and count == 1 and draw(st.integers(0, 6)) == 0:
            args.append(str(draw(good)))  # nargs="+": a second one
    if draw(st.integers(0, 9)) == 0:
        args.append(draw(anything))  # one argument too many
    if draw(st.integers(0, 5)) == 0:  # another data folder: any path of the world
        args += ["--data-dir", draw(paths)]
    return [*args, *LONG_COMMANDS.get(command, [])]


# -- running --------------------------------------------------------------------------------


@dataclass(frozen=True)
class Run:
    argv: tuple[str, ...]
    code: int | None
    out: str
    err: str
    hung: bool
    seconds: float


class Runner:
    """A server that imported the console once; each argument list runs in a child forked
    from it (see the module's doc). Use as a context manager."""

    def __init__(self, scratch: Scratch, timeout_s: float = TIMEOUT_S) -> None:
        self.scratch, self.timeout_s = scratch, timeout_s
        self.process: subprocess.Popen | None = None

    def __enter__(self) -> Runner:
        self.process = subprocess.Popen(
            [sys.executable, "-m", "tests.app.cli.fuzzing", str(self.scratch.folder / "cwd"),
             str(self.timeout_s)], cwd=ROOT, env=self.scratch.env, stdin=subprocess.PIPE,
            stdout=subprocess.PIPE, text=True, encoding="utf-8", errors="surrogateescape")
        ready = self.process.stdout.readline()
        if ready.strip() != "ready":
            raise RuntimeError(f"the fuzz server did not start: {ready!r}")
        return self

    def __exit__(self, *exc) -> None:
        if self.process is not None:
            self.process.stdin.close()
            self.process.wait(30)
            self.process.stdout.close()

    def run(self, args: list[str]) -> Run:
        self.process.stdin.write(json.dumps(args, ensure_ascii=True) + "\n")
        self.process.stdin.flush()
        answer = json.loads(self.process.stdout.readline())
        return Run(tuple(args), answer["code"], answer["out"], answer["err"], answer["hung"],
                   answer["seconds"])


_BUILT = None
"""The server's parser, (parser, commands) as app.cli.main.build_parser returns them."""


def _serve(cwd: str, timeout_s: float) -> None:
    """The server's loop: one JSON argument list a line in, one JSON result a line out."""
    import matplotlib

    matplotlib.use("Agg")
    # imported once here: every child has them
    import scipy.io  # noqa: F401

    import app.cli.main
    import app.exports.run
    import app.reports.build
    import app.trials.headless

    # what the commands import only when they run (a report's PDF writer, the study's
    # pandas, pyarrow and dask, the LSL library): imported here once, not in every child
    # (a report or a study analysis spent a second or more of each run importing them)
    for lazy in ("app.reports.pdf", "app.study.run", "app.study.outputs", "app.study.cluster",
                 "dask.dataframe", "pyarrow.dataset", "pylsl"):
        with contextlib.suppress(ImportError):  # a child then says what is missing itself
            importlib.import_module(lazy)
    from device.compiled.warmup import load_kernels

    load_kernels()  # loaded once here: a child's trial runs at once
    # the console's parser built once here too (about 20 ms a run): each child's main()
    # gets this one, its own copy by the fork, as it would build it (nothing in it depends
    # on the working folder or the time)
    global _BUILT
    _BUILT = app.cli.main.build_parser()

    out_file, err_file = Path(cwd) / ".fuzz-out", Path(cwd) / ".fuzz-err"
    print("ready", flush=True)
    for line in sys.stdin:
        args = json.loads(line)
        started = time.monotonic()
        child = os.fork()
        if child == 0:
            _child(args, cwd, out_file, err_file)
        hung, status = False, 0
        while True:
            done, status = os.waitpid(child, os.WNOHANG)
            if done:
                break
            if time.monotonic() - started > timeout_s:
                hung = True
                with contextlib.suppress(ProcessLookupError):
                    os.killpg(child, signal.SIGKILL)
                os.waitpid(child, 0)
                break
            time.sleep(0.002)
        code = None if hung else (os.waitstatus_to_exitcode(status))
        print(json.dumps({"code": code, "hung": hung, "seconds": time.monotonic() - started,
                          "out": _tail(out_file), "err": _tail(err_file)}), flush=True)


def _tail(path: Path, limit: int = 20_000) -> str:
    try:
        data = path.read_bytes()
    except OSError:
        return ""
    return data[-limit:].decode("utf-8", "surrogateescape")


def _child(args: list[str], cwd: str, out_file: Path, err_file: Path) -> None:
    code = 99
    try:
        os.setpgid(0, 0)  # its own group: a hang is killed with whatever it started
        os.chdir(cwd)
        for fd, path in ((1, out_file), (2, err_file)):
            target = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
            os.dup2(target, fd)
            os.close(target)
        sys.stdout = open(1, "w", encoding="utf-8", errors="surrogateescape",  # noqa: SIM115
                          closefd=False)
        sys.stderr = open(2, "w", encoding="utf-8", errors="backslashreplace",  # noqa: SIM115
                          closefd=False)
        from app.cli import main as cli

        if _BUILT is not None:
            cli.build_parser = lambda prog="rehab": _BUILT
        try:
            code = cli.main(args)
        except SystemExit as exc:
            code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 2)
    except BaseException:
        import traceback

        traceback.print_exc()
        code = 99
    finally:
        with contextlib.suppress(BaseException):
            sys.stdout.flush()
            sys.stderr.flush()
        os._exit(code if isinstance(code, int) and 0 <= code < 256 else 99)


# -- judging --------------------------------------------------------------------------------

ALLOWED_TO_CHANGE = ("registry.sqlite3", "registry.sqlite3-wal", "registry.sqlite3-shm")
WRITE_INTO_TRIALS = {("emg", "import"), ("emg", "mvc"), ("pose",), ("report",)}


def changed_files(before: dict, after: dict, args: tuple[str, ...], scratch: Scratch
                  ) -> list[str]:
    """Files and folders of the scratch world that were there before the run and are gone
    or different after it, other than those the argument list named (or lies in), the
    registry (commands register) and the data folder's trial files for the commands that
    add to a trial named by its id."""
    named = [os.path.abspath(os.path.join(scratch.folder / "cwd", a)) for a in args
             if a and "\x00" not in a]
    command = tuple(a for a in args[:2] if not a.startswith("-"))
    wrong = []
    for path, was in before.items():
        now = after.get(path)
        if now == was:
            continue
        if any(path == n or path.startswith(n.rstrip("/") + "/") for n in named):
            continue
        name = os.path.basename(path)
        if name in ALLOWED_TO_CHANGE or name.startswith(".fuzz-"):
            continue
        if (path.startswith(str(scratch.data / "trials") + "/")
                and (command in WRITE_INTO_TRIALS or command[:1] in WRITE_INTO_TRIALS)):
            continue
        if (path.startswith(str(scratch.data / "reports") + "/") and command[:1] == ("report",)
                and overwrite_asked(args)):
            continue  # `rehab report ID --overwrite` (or --force) writes its report again
        if (stat.S_ISDIR(was[0]) and now is not None and stat.S_ISDIR(now[0])
                and was[1] == now[1]):
            continue  # a folder whose entries changed: its files are judged themselves
        wrong.append(f"{path}: {'removed' if now is None else 'changed'}")
    return wrong


def overwrite_asked(args: tuple[str, ...]) -> bool:
    """Whether the argument list asks to replace an existing output, as the console's own
    parser reads it (`--force`, `--overwrite`, and any prefix argparse takes for them)."""
    from app.cli.main import build_parser

    parser, _ = build_parser()
    with contextlib.redirect_stderr(io.StringIO()), contextlib.suppress(SystemExit):
        read, _ = parser.parse_known_args(list(args))
        return bool(getattr(read, "overwrite", False))
    return False


def judge(run: Run, changed: list[str]) -> list[str]:
    """What is wrong with a run, in words: [] when nothing."""
    problems = []
    if run.hung:
        problems.append("hang")
    elif "Traceback (most recent call last)" in run.err or run.code in (70, 99) or (
            run.code is not None and run.code not in (0, 1, 2, 130)):
        problems.append("traceback")
    elif run.code == 2:
        lines = [line for line in run.err.splitlines() if line.strip()]
        if len(lines) != 1:
            problems.append("multi-line refusal" if lines else "silent refusal")
    if changed:
        problems.append("files changed")
    return problems


if __name__ == "__main__":
    _serve(sys.argv[1], float(sys.argv[2]))
