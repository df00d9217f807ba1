"""The built-in plan templates: JSON files in resources/plans, one plan each, read and
checked as any plan (core.plan). The clinic may add its own there; a template is copied
to a patient (the registry keeps the copy, app.records.registry.plans) and changed for
the day there, never in place. A template is written for a typical adult at the console's
default centre; copied to a patient, it is fitted to them (core.plan.fit_plan: a block
their arm or the robot cannot follow made smaller), and each change said in one line."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

from app.errors import AppError
from core.errors import CoreError
from core.plan import Plan, fit_plan
from core.trial import TrialParameters
from core.trial_check import SI_UNITS, MessageUnits

TEMPLATES_DIR = Path(__file__).resolve().parents[2] / "resources" / "plans"
MAX_TEMPLATE_BYTES = 256 * 1024


class TemplateError(AppError):
    """A template that is missing or cannot be read as a plan."""


@dataclass(frozen=True, slots=True)
class Template:
    """A template: its name (the file's stem), what it is for, and its plan."""

    name: str
    about: str
    plan: Plan
    fitted: tuple[str, ...] = ()
    """One line per block made smaller to fit the patient (load_template's fit_to)."""


def template_names(folder: Path = TEMPLATES_DIR) -> list[str]:
    return sorted(p.stem for p in folder.glob("*.json"))


def template_titles(folder: Path = TEMPLATES_DIR) -> list[tuple[str, str, str]]:
    """(name, title, about) of each template, for a list a person reads: the plan's own
    name ("Endurance", not the file's "endurance"); a template that cannot be read keeps
    its file's name, and the reason is its 'about' (copying it then says so too)."""
    titles = []
    for name in template_names(folder):
        try:
            template = load_template(name, folder)
        except TemplateError as exc:
            titles.append((name, name, str(exc)))
        else:
            titles.append((name, template.plan.name or name, template.about))
    return titles


def load_template(name: str, folder: Path = TEMPLATES_DIR, *,
                  fit_to: TrialParameters | None = None, robot=None,
                  units: MessageUnits = SI_UNITS) -> Template:
    """The template `name`, checked; TemplateError in one line naming the file and what is
    wrong (or, for an unknown name, the names there are). With `fit_to`, the setup of the
    patient it is copied to, its plan fitted to them (core.plan.fit_plan, said in `units`):
    the "First session" reach of 12 cm went 57.9 cm from the shoulder of an arm reaching
    57 cm and Start plan refused it."""
    names = template_names(folder)
    if name not in names:
        raise TemplateError(f"no plan template {name!r}; the templates are: "
                            f"{', '.join(names) or 'none'} (in {folder})")
    path = folder / f"{name}.json"
    try:
        if path.stat().st_size > MAX_TEMPLATE_BYTES:
            raise TemplateError(f"plan template {path}: larger than "
                                f"{MAX_TEMPLATE_BYTES // 1024} KiB; a plan is a few blocks")
        values = json.loads(path.read_text(encoding="utf-8"),
                            parse_constant=_refuse_constant)
    except (OSError, UnicodeDecodeError, ValueError, RecursionError) as exc:
        raise TemplateError(f"plan template {path} cannot be read: {exc}") from None
    if not isinstance(values, dict) or set(values) != {"about", "plan"} \
            or not isinstance(values["about"], str):
        raise TemplateError(f"plan template {path}: give an object with 'about' (text) and "
                            "'plan' (name and blocks)")
    try:
        plan = Plan.from_dict(values["plan"])
    except CoreError as exc:
        raise TemplateError(f"plan template {path}: {exc}") from None
    if fit_to is None:
        return Template(name, values["about"], plan)
    plan, fitted = fit_plan(plan, fit_to, robot, units)
    return Template(name, values["about"], plan, fitted)


def _refuse_constant(name: str):
    raise ValueError(f"{name} is not a number a plan may hold")
