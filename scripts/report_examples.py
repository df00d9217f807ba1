"""The report's page for the patient in each assistance mode and for a trial cut short by the
emergency stop, drawn from simulated trials, as PNGs for the docs and for review.

    .venv/bin/python scripts/report_examples.py [--out docs]

Writes report-example.png (as needed), report-example-thesis.png and
report-example-cut-short.png. Everything runs in a temporary data folder: one fictional
patient, simulated trials registered as the window registers them. The pages are the
figures the PDF is made of (app.reports.pdf.report_pages), drawn to PNG.
"""

from __future__ import annotations

import argparse
import dataclasses
import datetime
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import matplotlib  # noqa: E402

from app.records.datadir import DataDir  # noqa: E402
from app.records.registry import Registry  # noqa: E402
from app.reports.build import content_for_registry_trial  # noqa: E402
from app.reports.pdf import report_pages  # noqa: E402
from app.reports.pdf_sheet import RC  # noqa: E402
from app.trials.headless import save, simulate  # noqa: E402
from core.trial import THESIS_SUBJECT  # noqa: E402
from device.safety.faults import Fault  # noqa: E402

START = datetime.datetime(2026, 11, 23, 9, 30, tzinfo=datetime.UTC)
AS_NEEDED = THESIS_SUBJECT.replace(repetitions=3, assist="as-needed")
THESIS = THESIS_SUBJECT.replace(repetitions=3)


def emergency_stop(trial, fraction: float):
    """The trial as the loop ends one at the emergency stop, `fraction` of the way in."""
    n = int(len(trial.records) * fraction)
    detail = {"fault": Fault.ESTOP.label, "code": int(Fault.ESTOP)}
    event = {"time_s": n * trial.plan.period_s, "tick": n, "kind": "fault",
             "message": Fault.ESTOP.banner(detail), "values": detail}
    events = (*[e for e in trial.events if e["kind"] == "start"], event)
    return dataclasses.replace(trial, records=trial.records[:n], events=events,
                               status="faulted")


def register(registry: Registry, code: str, parameters, *, session: int, minutes: float,
             seed: int, edit=None) -> int:
    trial = simulate(parameters, patient="weak", seed=seed)
    if edit is not None:
        trial = edit(trial)
    started = START + datetime.timedelta(days=7 * (session - 1), minutes=minutes)
    begun = registry.begin_trial(code, parameters, backend="simulator",
                                 session_number=session, patient_kind="weak",
                                 started_at=started)
    metrics = save(trial, begun.path, subject_code=code).metrics.to_dict()
    reason = next((e["message"] for e in trial.events if e["kind"] == "fault"), "")
    registry.finish_trial(begun.trial_id, trial.status, metrics,
                          ended_at=started + datetime.timedelta(minutes=1), reason=reason)
    return begun.trial_id


def first_page(registry: Registry, trial_id: int, path: Path, dpi: float) -> None:
    with matplotlib.rc_context(RC):
        page = report_pages(content_for_registry_trial(registry, trial_id))[0]
        page.savefig(path, dpi=dpi)
    print(f"wrote {path.relative_to(ROOT) if path.is_relative_to(ROOT) else path}")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=ROOT / "docs")
    parser.add_argument("--dpi", type=float, default=80.0)
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="rehab-report-examples-") as folder:
        registry = Registry(DataDir(Path(folder) / "data"))
        code = registry.create_patient("Alex", "Example", side="right").code
        register(registry, code, AS_NEEDED, session=1, minutes=0, seed=1)
        register(registry, code, AS_NEEDED, session=2, minutes=0, seed=2)
        as_needed = register(registry, code, AS_NEEDED, session=2, minutes=5, seed=3)
        cut_short = register(registry, code, AS_NEEDED, session=2, minutes=10, seed=4,
                             edit=lambda trial: emergency_stop(trial, 0.35))
        register(registry, code, THESIS, session=1, minutes=10, seed=5)
        thesis = register(registry, code, THESIS, session=2, minutes=15, seed=6)
        for name, trial_id in (("report-example", as_needed),
                               ("report-example-thesis", thesis),
                               ("report-example-cut-short", cut_short)):
            first_page(registry, trial_id, args.out / f"{name}.png", args.dpi)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
