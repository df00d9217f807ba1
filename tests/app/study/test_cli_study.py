"""`rehab study analyse`: a folder or the registry's patients, each patient's progress table
as `rehab progress` has it, trials marked invalid left out unless asked, and every bad input
one line and exit code 2, refused before a cluster starts or a file is written."""

from __future__ import annotations

import re
import shutil
import subprocess

import numpy as np
import pandas as pd
import pytest

from app.cli.study import query_line
from app.records.datadir import DataDir
from app.records.registry import Registry
from app.reports.progress import progress
from app.study import sources
from app.study.run import analyse_study
from tests.app.cli.running import run
from tests.app.study.conftest import SOUND
from tests.old_analysis import analysed_as_before


def one_line_refusal(code, out, err):
    assert code == 2, err
    assert out == ""
    assert err.count("\n") == 1, err
    assert err.startswith("rehab study analyse: error: ") or err.startswith("rehab: error:")
    return err


def test_a_folder_is_analysed_listing_what_could_not_be_read(study, client, tmp_path, capsys,
                                                             data):
    out_folder = tmp_path / "out"
    code, out, err = run(["study", "analyse", str(study), "--output", str(out_folder)],
                         capsys)
    assert code == 1, err  # analysed, with files that could not be
    assert f"analysed {SOUND} trial(s) of the folder {study} on 2 worker(s)" in out
    assert out.count("  not analysed: ") == 3
    assert "  not analysed: other.h5: " in out
    assert sorted(p.name for p in out_folder.iterdir()) == ["failures.csv", "trials",
                                                            "trials.csv"]
    table = pd.read_csv(out_folder / "trials.csv")
    assert len(table) == SOUND
    # the query it prints runs as pasted, from any folder ('.venv/bin/python' ran only from
    # the console's), and on a folder whose name a shell or SQL would read otherwise
    (query,) = [line.split("query: ", 1)[1] for line in out.splitlines() if "query: " in line]
    odd = tmp_path / "it's \"a\" $HOME `study`"
    odder = tmp_path / "wow!"  # quoted otherwise: ! is read between double quotes too
    shutil.copytree(out_folder / "trials", odd)
    shutil.copytree(out_folder / "trials", odder)
    for line in (query, query_line(odd), query_line(odder)):
        counted = subprocess.run(["bash", "-c", line], cwd=tmp_path, capture_output=True,
                                 text=True, timeout=120)
        assert counted.returncode == 0, counted.stderr
        assert sum(int(n) for n in re.findall(r"│\s*\S+\s*│\s*(\d+)\s*│", counted.stdout)) \
            == SOUND, counted.stdout
    # again: the results are kept, in one line, before any work
    code, out, err = run(["study", "analyse", str(study), "--output", str(out_folder)],
                         capsys)
    assert "already exists and is kept" in one_line_refusal(code, out, err)
    # on a cluster's scheduler (the tests' own local one)
    code, out, err = run(["study", "analyse", str(study), "--output", str(out_folder),
                          "--overwrite", "--partition-by", "site", "--scheduler",
                          client.scheduler.address], capsys)
    assert code == 1, err
    assert f"analysed {SOUND} trial(s)" in out
    assert sorted(p.name for p in (out_folder / "trials").iterdir()) == [
        "site=north", "site=south"]


def test_bad_inputs_are_one_line_and_exit_2(study, tmp_path, capsys, data):
    empty = tmp_path / "empty"
    empty.mkdir()
    (empty / "readme.txt").write_text("no trials here")
    taken = tmp_path / "taken"
    (taken / "trials").mkdir(parents=True)
    out = ["--output", str(tmp_path / "out")]
    cases = {
        "missing folder": (["study", "analyse", str(tmp_path / "nowhere"), *out],
                           "does not exist"),
        "empty folder": (["study", "analyse", str(empty), *out], "holds no trial files"),
        "not an address": (["study", "analyse", str(study), "--scheduler", "tcp://no port",
                            *out], "not an address"),
        "no port": (["study", "analyse", str(study), "--scheduler", "tcp://somehost", *out],
                    "--scheduler"),
        "not Dask's": (["study", "analyse", str(study), "--scheduler", "http://host:80",
                        *out], "Dask does not speak 'http'"),
        "output exists": (["study", "analyse", str(study), "--output", str(taken)],
                          "already exists and is kept"),
        "output in the data folder": (["study", "analyse", str(study), "--output",
                                       str(data / "trials" / "out")], "inside the data folder"),
        "no workers": (["study", "analyse", str(study), "--workers", "0", *out], "--workers"),
        "empty query": (["study", "analyse", " ", *out], "empty"),
        "no registry": (["study", "analyse", "P1ZTTAQ", *out], "no registry"),
        # a query in the wrong case used to be taken for a folder: "does not exist"
        "code in lower case": (["study", "analyse", "p1zttaq", *out],
                               "is no folder; for the registry give 'P1ZTTAQ'"),
        "ALL": (["study", "analyse", "ALL", *out], "for the registry give 'all'"),
    }
    for name, (argv, words) in cases.items():
        code, printed, err = run(argv, capsys)
        assert words in one_line_refusal(code, printed, err), name
    assert not (tmp_path / "out").exists()
    assert list((taken / "trials").iterdir()) == []


def test_an_unreachable_scheduler_is_one_line_and_exit_2(study, tmp_path, capsys, data):
    # nothing listens on port 1 of this machine: refused at once, whatever the timeout
    code, out, err = run(["study", "analyse", str(study), "--scheduler", "127.0.0.1:1",
                          "--connect-timeout", "1", "--output", str(tmp_path / "out")],
                         capsys)
    assert "cannot reach the Dask scheduler at tcp://127.0.0.1:1" in one_line_refusal(
        code, out, err)
    assert not (tmp_path / "out").exists()


def test_a_refused_port_is_not_taken_for_a_silent_service_when_the_wait_ends_first(
        study, tmp_path, capsys, data, monkeypatch):
    """Dask retries a refused connection until its timeout, the same as the handshake's
    wait: in a fresh-clone check on a loaded machine the wait ended first and port 1 was
    said to have 'took the connection but did not answer'."""
    import asyncio

    import distributed.comm

    async def slower(*args, **kwargs):  # Dask still retrying when the wait ends
        await asyncio.sleep(60)

    monkeypatch.setattr(distributed.comm, "connect", slower)
    code, out, err = run(["study", "analyse", str(study), "--scheduler", "127.0.0.1:1",
                          "--connect-timeout", "1", "--output", str(tmp_path / "out")],
                         capsys)
    assert "cannot reach the Dask scheduler at tcp://127.0.0.1:1 (" in one_line_refusal(
        code, out, err)


@pytest.fixture
def not_dask():
    """`listen(greeting)`: a port on 127.0.0.1 where a service that is not Dask takes
    connections, says `greeting` (b'': nothing, as a web server waiting for a request) and
    keeps them open; its address."""
    import contextlib
    import socket
    import threading

    servers: list[socket.socket] = []
    threads: list[threading.Thread] = []
    opened: list[socket.socket] = []

    def listen(greeting: bytes) -> str:
        server = socket.socket()
        server.bind(("127.0.0.1", 0))
        server.listen(4)
        servers.append(server)

        def serve() -> None:
            while True:
                try:
                    conn, _ = server.accept()
                except OSError:
                    return  # closed at the end
                opened.append(conn)
                conn.sendall(greeting)
        threads.append(threading.Thread(target=serve, daemon=True))
        threads[-1].start()
        return f"127.0.0.1:{server.getsockname()[1]}"
    yield listen
    # the listeners first, and their threads ended: a connection accepted while the
    # others were closed was left open (a ResourceWarning failing a later test)
    for server in servers:
        with contextlib.suppress(OSError):
            server.shutdown(socket.SHUT_RDWR)
        server.close()
    for thread in threads:
        thread.join(5)
    for sock in opened:
        sock.close()


@pytest.mark.parametrize(("greeting", "words"), [
    (b"", "took the connection but did not answer as a Dask scheduler within 2 s (another "
     "service on that port?): check the address"),
    (b"SSH-2.0-OpenSSH_9.2p1 Debian-2\r\n" * 4, "answered, but not as a Dask scheduler "
     "(another service on that port?): check the address"),
])
def test_a_service_that_is_not_a_scheduler_is_one_line_and_exit_2(study, tmp_path, capsys,
                                                                  not_dask, greeting, words):
    """Dask bounds the connection but not its handshake: a silent service held the command
    for ever, and a talking one said 'the input is too large to hold in memory'."""
    address = not_dask(greeting)
    code, out, err = run(["study", "analyse", str(study), "--scheduler", address,
                          "--connect-timeout", "2", "--output", str(tmp_path / "out")],
                         capsys)
    assert f"tcp://{address} {words}" in one_line_refusal(code, out, err)
    assert not (tmp_path / "out").exists()


def test_a_tls_scheduler_without_certificates_is_one_line_and_exit_2(study, tmp_path, capsys,
                                                                     not_dask):
    """It was an internal error (Dask's TypeError: TLS expects a `ssl_context`)."""
    address = not_dask(b"")
    code, out, err = run(["study", "analyse", str(study), "--scheduler", f"tls://{address}",
                          "--connect-timeout", "2", "--output", str(tmp_path / "out")],
                         capsys)
    assert (f"tls://{address} asks for TLS, and Dask's configuration has no certificates for "
            "it (distributed.comm.tls: ca-file, client cert and key): set them, or give the "
            "scheduler's tcp:// address") in one_line_refusal(code, out, err)


@pytest.fixture
def registered(data, patient, capsys):
    """Two patients of the data folder's registry with two simulated trials each, the
    first patient's second trial marked invalid."""
    code, out, err = run(["patients", "add", "--first-name", "Bo", "--last-name", "Other",
                          "--body-mass", "70", "--upper-arm", "0.30", "--forearm", "0.29",
                          "--side", "right", "--shoulder", "-0.12", "0.73"], capsys)
    assert code == 0, err
    codes = [patient, out.strip()]
    for who in codes:
        for shape in ("d", "circle"):
            code, _, err = run(["run", "--code", who, "--repetitions", "1", "--trajectory",
                                shape, "--seed", "3"], capsys)
            assert code == 0, err
    registry = Registry(DataDir(data))
    invalid = registry.trials_for_patient(codes[0])[1].id
    code, _, err = run(["invalid", str(invalid), "--reason", "let go of the handle", "--by",
                        "K. Lee"], capsys)
    assert code == 0, err
    return registry, codes, invalid


def test_the_registry_gives_each_patients_progress_table(registered, client, tmp_path,
                                                          capsys):
    registry, codes, invalid = registered
    result = analyse_study(sources.from_registry(registry, "all"), client)
    assert result.failures.empty
    assert result.selection.left_out_invalid == 1
    assert invalid not in set(result.trials["trial_id"])
    for code in codes:
        header, rows = progress(registry, code).table()
        ours = result.trials[result.trials["patient"] == code]
        assert list(ours["trial_id"]) == [row[0] for row in rows]
        assert list(ours["session"]) == [row[1] for row in rows]
        assert list(ours["trial"]) == [row[2] for row in rows]
        # `rehab run` measured its trials a block at a time as it wrote them
        # (app.trials.analysis.analyse_stored: the same figures to rounding)
        for name in header[len(header) - len(progress(registry, code).metric_names):]:
            registered_values = [row[header.index(name)] for row in rows]
            np.testing.assert_allclose(ours[f"metric_{name}"], registered_values, rtol=1e-9,
                                       atol=1e-12, equal_nan=True, err_msg=name)
    # with the invalid trial, saying why
    every = analyse_study(sources.from_registry(registry, codes[0], include_invalid=True),
                          client)
    marked = every.trials[every.trials["trial_id"] == invalid]
    assert list(marked["invalid_reason"]) == ["let go of the handle"]
    # the command, on the data folder's own exports/study by default
    on = ["--scheduler", client.scheduler.address]
    code, out, err = run(["study", "analyse", codes[1], *on], capsys)
    assert code == 0, err
    assert f"analysed 2 trial(s) of patient {codes[1]}" in out
    assert (registry.data_dir.root / "exports" / "study" / "trials.csv").is_file()
    # the data folder's trials/ as a folder: its marks still leave the invalid trial out
    code, out, err = run(["study", "analyse", str(registry.data_dir.root / "trials"),
                          "--output", str(tmp_path / "folder"), *on], capsys)
    assert code == 0, err
    assert "analysed 3 trial(s)" in out
    assert "1 trial(s) marked invalid left out" in out


def test_a_trial_the_registry_holds_older_figures_of_is_named_until_reanalysed(
        data, patient, client, tmp_path, capsys, monkeypatch):
    with monkeypatch.context() as patch:  # recorded by the analysis before 2026-12-05
        analysed_as_before(patch)
        code, _, err = run(["run", "--code", patient, "--repetitions", "1", "--seed", "3"],
                           capsys)
    assert code == 0, err
    on = ["--scheduler", client.scheduler.address]
    for source, output in ((patient, "stale"), (str(data / "trials"), "folder")):
        code, out, err = run(["study", "analyse", source, "--output", str(tmp_path / output),
                              *on], capsys)
        assert code == 0, err
        assert "1 trial(s) have figures here that differ from the registry's" in out
        table = pd.read_csv(tmp_path / output / "trials.csv", keep_default_na=False)
        assert list(table["registry_differs"]) == ["robot_work_share, robot_help_work_J"]
    code, _, err = run(["reanalyse", "--patient", patient, "--by", "R. Searcher"], capsys)
    assert code == 0, err
    code, out, err = run(["study", "analyse", patient, "--output", str(tmp_path / "now"),
                          *on], capsys)
    assert code == 0, err
    assert "differ from the registry's" not in out
    table = pd.read_csv(tmp_path / "now" / "trials.csv", keep_default_na=False)
    assert list(table["registry_differs"]) == [""]


def test_the_command_line_starts_without_dask():
    import subprocess
    import sys

    code = ("import sys, app.cli.main; app.cli.main.build_parser(); "
            "print(sorted(m for m in ('dask', 'distributed', 'pyarrow', 'duckdb') "
            "if m in sys.modules))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=True)
    assert done.stdout.strip() == "[]"
