"""The fake Trigno Control Utility of the device tests (tests/device/fakes/trigno_server.py),
loaded by its path: tests/device/fakes is not a package (the other vendors' fakes beside it
are folders of their own). One loader for every test that streams from it; each call loads
a module of its own, as each test module did."""

from __future__ import annotations

import importlib.util
from pathlib import Path

PATH = Path(__file__).parent / "device" / "fakes" / "trigno_server.py"


def fake_trigno():
    spec = importlib.util.spec_from_file_location("trigno_server", PATH)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module
