"""The clinical scales a therapist records per session, and what each accepts (issue 31).

The robot measures a patient only while they move it; the instruments clinics already
trust are scored by the therapist. The registry keeps them per session (schema v8,
app.records.registry.clinical) in the form each is scored:

* **Fugl-Meyer upper extremity, motor** (`fugl_meyer`, 0-66): Fugl-Meyer et al. 1975,
  Scand J Rehabil Med 7:13; the item list and maxima of the standardised protocol,
  Gladstone et al. 2002, Neurorehabil Neural Repair 16:232. Four parts: A upper
  extremity (0-36), B wrist (0-10), C hand (0-14), D coordination/speed (0-6); 33 items
  scored 0-2 (the two reflex items of A.I 0 or 2). Recorded as all 33 items, as the four
  part totals, or as the total alone; the total is the sum of what was given.
* **Action Research Arm Test** (`arat`, 0-57): Lyle 1981, Int J Rehabil Res 4:483; four
  subscales grasp (0-18), grip (0-12), pinch (0-18), gross movement (0-9). Recorded as
  the four subscales or the total alone.
* **Modified Ashworth Scale** (`ashworth`) per muscle group: Bohannon & Smith 1987, Phys
  Ther 67:206; grades 0, 1, 1+, 2, 3, 4. An ordinal scale has no total; for a plot and a
  rank correlation each grade is coded 0, 1, 1.5, 2, 3, 4 (`ASHWORTH_CODES`, the usual
  coding; Spearman's rho does not depend on it).
* **Pain** (`pain`, 0-10 numeric rating scale, 0 none, 10 worst imaginable) and
  **fatigue** (`fatigue`, 0-10 numeric rating scale, 0 none, 10 worst imaginable).

Every value is a whole number in its range (an Ashworth grade one of its six): anything
else is refused in one line naming the scale, the item and the range. `scale_values`
gives each entry's plotted values under keys Progress and the reports read.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

from app.errors import InvalidRecordError


@dataclass(frozen=True, slots=True)
class ScaleItem:
    """One scored item: its key, part, label and the scores it allows."""

    key: str
    part: str
    label: str
    scores: tuple[int, ...] = (0, 1, 2)

    @property
    def maximum(self) -> int:
        return max(self.scores)


FUGL_MEYER = "fugl_meyer"
ARAT = "arat"
ASHWORTH = "ashworth"
PAIN = "pain"
FATIGUE = "fatigue"
SCALES = (FUGL_MEYER, ARAT, ASHWORTH, PAIN, FATIGUE)
"""The scales' ids, as the registry, the command line and Progress name them."""

SCALE_LABELS = {
    FUGL_MEYER: "Fugl-Meyer UE motor",
    ARAT: "ARAT",
    ASHWORTH: "Modified Ashworth",
    PAIN: "Pain (NRS)",
    FATIGUE: "Fatigue (NRS)",
}
SCALE_MAXIMA = {FUGL_MEYER: 66, ARAT: 57, PAIN: 10, FATIGUE: 10}
"""The total's range 0-maximum of each scale with a total (Ashworth has none)."""

FUGL_MEYER_PARTS = {"A": 36, "B": 10, "C": 14, "D": 6}
FUGL_MEYER_PART_LABELS = {"A": "upper extremity", "B": "wrist", "C": "hand",
                          "D": "coordination/speed"}
FUGL_MEYER_ITEMS: tuple[ScaleItem, ...] = (
    ScaleItem("a1_reflex_flexors", "A", "I. reflex activity, flexors (biceps, finger flexors)",
              (0, 2)),
    ScaleItem("a1_reflex_extensors", "A", "I. reflex activity, extensors (triceps)", (0, 2)),
    ScaleItem("a2_shoulder_retraction", "A", "II. flexor synergy: shoulder retraction"),
    ScaleItem("a2_shoulder_elevation", "A", "II. flexor synergy: shoulder elevation"),
    ScaleItem("a2_shoulder_abduction", "A", "II. flexor synergy: shoulder abduction (90°)"),
    ScaleItem("a2_shoulder_external_rotation", "A",
              "II. flexor synergy: shoulder external rotation"),
    ScaleItem("a2_elbow_flexion", "A", "II. flexor synergy: elbow flexion"),
    ScaleItem("a2_forearm_supination", "A", "II. flexor synergy: forearm supination"),
    ScaleItem("a2_shoulder_adduction_internal_rotation", "A",
              "II. extensor synergy: shoulder adduction/internal rotation"),
    ScaleItem("a2_elbow_extension", "A", "II. extensor synergy: elbow extension"),
    ScaleItem("a2_forearm_pronation", "A", "II. extensor synergy: forearm pronation"),
    ScaleItem("a3_hand_to_lumbar_spine", "A", "III. mixing synergies: hand to lumbar spine"),
    ScaleItem("a3_shoulder_flexion_0_90", "A", "III. mixing synergies: shoulder flexion 0-90°"),
    ScaleItem("a3_pronation_supination_elbow_90", "A",
              "III. mixing synergies: pronation-supination, elbow at 90°"),
    ScaleItem("a4_shoulder_abduction_0_90", "A", "IV. little or no synergy: shoulder "
              "abduction 0-90°"),
    ScaleItem("a4_shoulder_flexion_90_180", "A", "IV. little or no synergy: shoulder "
              "flexion 90-180°"),
    ScaleItem("a4_pronation_supination_elbow_0", "A", "IV. little or no synergy: "
              "pronation-supination, elbow at 0°"),
    ScaleItem("a5_normal_reflex_activity", "A", "V. normal reflex activity"),
    ScaleItem("b_stability_elbow_90", "B", "stability at 15° dorsiflexion, elbow at 90°"),
    ScaleItem("b_flexion_extension_elbow_90", "B", "repeated dorsiflexion/volar flexion, "
              "elbow at 90°"),
    ScaleItem("b_stability_elbow_0", "B", "stability at 15° dorsiflexion, elbow at 0°"),
    ScaleItem("b_flexion_extension_elbow_0", "B", "repeated dorsiflexion/volar flexion, "
              "elbow at 0°"),
    ScaleItem("b_circumduction", "B", "circumduction"),
    ScaleItem("c_mass_flexion", "C", "mass flexion"),
    ScaleItem("c_mass_extension", "C", "mass extension"),
    ScaleItem("c_grasp_hook", "C", "grasp a: hook"),
    ScaleItem("c_grasp_thumb_adduction", "C", "grasp b: thumb adduction"),
    ScaleItem("c_grasp_pincer", "C", "grasp c: pincer"),
    ScaleItem("c_grasp_cylinder", "C", "grasp d: cylinder"),
    ScaleItem("c_grasp_spherical", "C", "grasp e: spherical"),
    ScaleItem("d_tremor", "D", "tremor"),
    ScaleItem("d_dysmetria", "D", "dysmetria"),
    ScaleItem("d_time", "D", "time (finger to nose, 5 times)"),
)

ARAT_SUBSCALES = {"grasp": 18, "grip": 12, "pinch": 18, "gross": 9}

ASHWORTH_GRADES = ("0", "1", "1+", "2", "3", "4")
ASHWORTH_CODES = {"0": 0.0, "1": 1.0, "1+": 1.5, "2": 2.0, "3": 3.0, "4": 4.0}
ASHWORTH_GROUPS = ("shoulder_adductors", "shoulder_internal_rotators", "elbow_flexors",
                   "elbow_extensors", "forearm_pronators", "wrist_flexors", "finger_flexors")


@dataclass(frozen=True, slots=True)
class ScaleScore:
    """A scale's score as stored: `total` (None for Ashworth) and its `detail`: the
    Fugl-Meyer parts and items, the ARAT subscales or the Ashworth grades per group, as
    given (a total given alone has no detail)."""

    scale: str
    total: int | None
    detail: dict


def _whole(what: str, value: object, low: int, high: int) -> int:
    if isinstance(value, float) and value.is_integer():
        value = int(value)
    if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
        raise InvalidRecordError(f"{what} = {value!r} is out of range; give a whole number "
                                 f"{low}-{high}")
    return value


def _mapping(what: str, values: object, keys: tuple[str, ...] | dict) -> dict:
    if not isinstance(values, Mapping):
        raise InvalidRecordError(f"{what}: give a mapping of {', '.join(keys)} to scores")
    unknown = sorted(str(k) for k in set(values) - set(keys))
    if unknown:
        raise InvalidRecordError(f"{what}: {', '.join(unknown)} unknown; give "
                                 f"{', '.join(keys)}")
    return dict(values)


def _all_of(what: str, values: dict, keys) -> None:
    missing = [k for k in keys if k not in values]
    if missing:
        raise InvalidRecordError(f"{what}: {', '.join(missing)} missing; give all "
                                 f"{len(keys)} (or the total alone)")


def _one_form(scale: str, total, forms: dict) -> None:
    given = [name for name, value in (("total", total), *forms.items()) if value is not None]
    if len(given) != 1:
        raise InvalidRecordError(
            f"{SCALE_LABELS[scale]}: give one of {', '.join(('total', *forms))}"
            + (f", not {' and '.join(given)}" if given else ""))


def score(scale: str, *, total: int | None = None, parts: Mapping | None = None,
          items: Mapping | None = None, grades: Mapping | None = None) -> ScaleScore:
    """A scale's score checked against its ranges: `total` alone, or the Fugl-Meyer
    `parts` (A-D) or `items` (all 33), the ARAT `parts` (its subscales), the Ashworth
    `grades` per muscle group. InvalidRecordError in one line for anything out of range."""
    if scale not in SCALES:
        raise InvalidRecordError(f"scale {scale!r} unknown; give one of {', '.join(SCALES)}")
    label = SCALE_LABELS[scale]
    if scale == ASHWORTH:
        if total is not None or parts is not None or items is not None:
            raise InvalidRecordError("Modified Ashworth has no total: give the grade of each "
                                     "muscle group measured")
        return ScaleScore(scale, None, {"grades": _ashworth(grades)})
    if grades is not None:
        raise InvalidRecordError(f"{label} has no grades per muscle group; give its total")
    if scale == FUGL_MEYER:
        _one_form(scale, total, {"parts": parts, "items": items})
        if items is not None:
            given = _mapping(f"{label} items", items, tuple(i.key for i in FUGL_MEYER_ITEMS))
            _all_of(f"{label} items", given, [i.key for i in FUGL_MEYER_ITEMS])
            checked = {}
            for item in FUGL_MEYER_ITEMS:
                value = _whole(f"{label} item {item.key}", given[item.key], 0, item.maximum)
                if value not in item.scores:
                    raise InvalidRecordError(
                        f"{label} item {item.key} = {value} is not a score it has; give "
                        f"{' or '.join(map(str, item.scores))}")
                checked[item.key] = value
            sums = {part: sum(checked[i.key] for i in FUGL_MEYER_ITEMS if i.part == part)
                    for part in FUGL_MEYER_PARTS}
            return ScaleScore(scale, sum(sums.values()), {"parts": sums, "items": checked})
        if parts is not None:
            sums = _parts(label, parts, FUGL_MEYER_PARTS)
            return ScaleScore(scale, sum(sums.values()), {"parts": sums})
    elif scale == ARAT:
        if items is not None:
            raise InvalidRecordError("ARAT: give its four subscales or its total")
        _one_form(scale, total, {"parts": parts})
        if parts is not None:
            sums = _parts(label, parts, ARAT_SUBSCALES)
            return ScaleScore(scale, sum(sums.values()), {"parts": sums})
    elif parts is not None or items is not None:
        raise InvalidRecordError(f"{label} is one number 0-10; give it alone")
    if total is None:
        raise InvalidRecordError(f"{label}: give its score 0-{SCALE_MAXIMA[scale]}")
    return ScaleScore(scale, _whole(label, total, 0, SCALE_MAXIMA[scale]), {})


def _parts(label: str, parts: Mapping, maxima: dict[str, int]) -> dict[str, int]:
    given = _mapping(f"{label} parts", parts, maxima)
    _all_of(f"{label} parts", given, list(maxima))
    return {part: _whole(f"{label} {part}", given[part], 0, high)
            for part, high in maxima.items()}


def _ashworth(grades: Mapping | None) -> dict[str, str]:
    if not grades:
        raise InvalidRecordError("Modified Ashworth: give the grade of at least one muscle "
                                 f"group ({', '.join(ASHWORTH_GROUPS)})")
    given = _mapping("Modified Ashworth", grades, ASHWORTH_GROUPS)
    out = {}
    for group in ASHWORTH_GROUPS:
        if group not in given:
            continue
        grade = given[group]
        grade = str(grade) if isinstance(grade, int) and not isinstance(grade, bool) else grade
        if grade not in ASHWORTH_GRADES:
            raise InvalidRecordError(f"Modified Ashworth {group} = {grades[group]!r} is not a "
                                     f"grade; give one of {', '.join(ASHWORTH_GRADES)}")
        out[group] = grade
    return out


def scale_values(scale: str, total: int | None, detail: dict) -> dict[str, float]:
    """What Progress and the reports plot of one entry: `<scale>` (the total), the parts
    (`fugl_meyer_A`…, `arat_grasp`…) and each Ashworth group coded (`ashworth_<group>`,
    ASHWORTH_CODES)."""
    values: dict[str, float] = {}
    if total is not None:
        values[scale] = float(total)
    for part, value in detail.get("parts", {}).items():
        values[f"{scale}_{part}"] = float(value)
    for group, grade in detail.get("grades", {}).items():
        values[f"{scale}_{group}"] = ASHWORTH_CODES[grade]
    return values


def value_label(key: str) -> str:
    """The label of a scale_values key, for an axis or a table."""
    for scale in SCALES:
        if key == scale:
            return SCALE_LABELS[scale]
        if key.startswith(scale + "_"):
            rest = key[len(scale) + 1:]
            if scale == FUGL_MEYER:
                return f"Fugl-Meyer {rest} ({FUGL_MEYER_PART_LABELS.get(rest, rest)})"
            return f"{SCALE_LABELS[scale]} {rest.replace('_', ' ')}"
    return key
