"""Every malformed norms file is refused in one line naming the file and the field; a
corrupted file (bytes flipped, cut short) is refused or reads exactly as written, never
differently in silence."""

from __future__ import annotations

import json
import random

import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from app.norms import NormsFileError, load_norms, write_norms
from app.norms.modelfile import parse_norms
from tests.app.norms.handmade import handmade


def _set(document: dict, path: str, value) -> dict:
    *parents, last = path.split("/")
    node = document
    for key in parents:
        node = node[int(key)] if isinstance(node, list) else node[key]
    if value is _DELETE:
        del node[last]
    else:
        node[last] = value
    return document


class _Deleted:
    """The mark of a key taken out; its repr names the tests the same in every process
    (pytest-xdist's workers must collect the same ids: an object()'s address differed)."""

    def __repr__(self) -> str:
        return "<deleted>"


_DELETE = _Deleted()
RT = "figures/vgr_reaction_time_s"

MALFORMED = [
    ("format", "rehab-console-model", "is not a norms file"),
    ("format_version", 2, "newer than this console's 1"),
    ("format_version", "1", "not a whole number"),
    ("source", "", "'source' must say who"),
    ("simulated", "yes", "'simulated' must be true or false"),
    ("mdc", 1, "has 'mdc'"),
    ("covariates/age_years", [20], "covariates.age_years"),
    ("covariates/age_years", [80, 20], "covariates.age_years[1]"),
    ("covariates/sex", ["female", "other"], "covariates: sex"),
    ("covariates/robot", [], "covariates: levels of robot"),
    ("covariates/handedness", _DELETE, "covariates: lacks 'handedness'"),
    ("figures", {}, "figures: must be an object with at least one figure"),
    ("figures/vgr_reaction_s", handmade()["figures"]["vgr_reaction_time_s"],
     "figures.vgr_reaction_s: is not a figure this console measures"),
    (f"{RT}/mdc_95", 0.1, "has 'mdc_95'"),
    (f"{RT}/residual_sd", 0.0, "residual_sd: '0.0' is not a finite number more than 0"),
    (f"{RT}/residual_sd", -1, "residual_sd"),
    (f"{RT}/residual_sd", 1e300, "residual_sd"),
    (f"{RT}/n", 3, "n: '3' is not a whole number from 7"),
    (f"{RT}/n", 100.5, "n: '100.5' is not a whole number"),
    (f"{RT}/worse", "lower", "contradicts the figure, which is worse higher"),
    (f"{RT}/worse", "up", "is not one of higher, lower, both"),
    (f"{RT}/transform/kind", "log", "is not one of box-cox"),
    (f"{RT}/transform/lambda", 50, "lambda"),
    (f"{RT}/transform/lambda", True, "lambda"),
    (f"{RT}/transform", {"kind": "yeo-johnson", "shift": 1.0}, "only Box-Cox shifts"),
    # a negative Box-Cox shift on what cannot be negative: those values were read and
    # then never scored (a task's least distances are its healthiest people)
    ("figures/vgr_max_speed_m_s/transform", {"kind": "box-cox", "lambda": 0.5, "shift": -0.1},
     "vgr_max_speed_m_s.transform.shift: -0.1 leaves values the figure can take from 0 "
     "to 0.1 outside Box-Cox's domain (x + shift > 0): no Z-score for them; give a shift "
     "of at least 0."),
    # a shift no figure needs: Box-Cox becomes a straight line and the figure loses its
    # digits (10¹² was read before)
    (f"{RT}/transform/shift", 1e12, "vgr_reaction_time_s.transform.shift: 1e+12 is beyond "
     "±1000, further than values the figure can take ever need moving to be above 0; refit "
     "the norms (`rehab norms fit`) or give the shift that puts the least of them just "
     "above 0."),
    ("tasks/reaching/transform/shift", 5000.0, "tasks.reaching.transform.shift: 5000 is "
     "beyond ±1000"),
    (f"{RT}/transform/shift", -2000.0, "vgr_reaction_time_s.transform.shift: -2000 is "
     "beyond ±1000"),
    ("tasks/reaching/transform/shift", -2.0, "tasks.reaching.transform.shift: -2 leaves "
     "the task's distances (eq. 3; the least are the best) from 0 to 2 outside"),
    ("figures/vgr_max_speed_m_s/transform/lambda", 0.5, "vgr_max_speed_m_s.transform.lambda: "
     "0.5 on a transform 'none', which has no λ"),
    (f"{RT}/coefficients/robot=quanser", 0.1, "has 'robot=quanser'"),
    (f"{RT}/coefficients/sex=male", _DELETE, "lacks 'sex=male'"),
    (f"{RT}/coefficients/age_years", "0.01", "age_years"),
    (f"{RT}/mdc95", -0.1, "mdc95"),
    (f"{RT}/icc", 1.5, "icc"),
    ("tasks", [], "tasks: must be an object"),
    ("tasks/reach", {}, "tasks.reach: is not a task of this console"),
    ("tasks/reaching/figures", [], "must list the figures it combines"),
    ("tasks/reaching/figures", ["vgr_reaction_time_s", "vgr_reaction_time_s"], "none twice"),
    ("tasks/reaching/figures", ["vgr_sparc"], "combines 'vgr_sparc', which the file's"),
    ("tasks/reaching/sd", 0, "tasks.reaching.sd"),
    ("tasks/reaching/n", 2, "tasks.reaching.n"),
    ("tasks/reaching/mean", _DELETE, "lacks 'mean'"),
    ("calibration", [1], "'calibration' must be an object"),
]


@pytest.mark.parametrize(("path", "value", "words"), MALFORMED,
                         ids=[f"{p}={v!r}"[:60] for p, v, _ in MALFORMED])
def test_every_malformed_file_is_refused_in_one_line(tmp_path, path, value, words):
    file = tmp_path / "norms.json"
    file.write_text(json.dumps(_set(handmade(), path, value)))
    with pytest.raises(NormsFileError) as caught:
        load_norms(file)
    text = str(caught.value)
    assert words in text
    assert text.startswith(f"norms file {file}: ")
    assert "\n" not in text


def test_a_shift_or_lambda_json_cannot_hold_is_refused_in_a_document():
    """NaN and infinities never reach the reader from a file (JSON refuses them); a
    document built in Python is checked the same."""
    for path, value in ((f"{RT}/transform/shift", float("nan")),
                        (f"{RT}/transform/shift", float("inf")),
                        (f"{RT}/transform/lambda", float("nan")),
                        ("tasks/reaching/transform/shift", float("-inf"))):
        with pytest.raises(NormsFileError, match=path.replace("/", ".").replace(
                "figures.", "")):
            parse_norms(_set(handmade(), path, value))


def test_a_negative_shift_on_an_unbounded_figure_is_read_and_said_at_scoring():
    """A reaction time can be negative (an anticipation): no shift covers every value,
    so the file's shift stands and a value outside it is refused in one line, naming the
    domain (a shift of 0 printed 'more than -0')."""
    from app.norms import Covariates, NormsError

    who = Covariates(60, "female", "right", "right", "simulator-realistic")
    for shift, value, bound in ((-0.3, 0.25, "more than 0.3"), (0.0, 0.0, "more than 0)")):
        model = parse_norms(_set(handmade(), f"{RT}/transform/shift", shift))
        with pytest.raises(NormsError) as caught:
            model.z("vgr_reaction_time_s", value, who)
        assert f"is outside the norms' Box-Cox domain ({bound}" in str(caught.value)
        assert "\n" not in str(caught.value)


@pytest.mark.parametrize(("content", "words"), [
    (b"", "is not a JSON norms file"),
    (b"{\"format\": ", "is not a JSON norms file"),
    (b"\xff\xfe", "is not a JSON norms file"),
    (b"[1, 2]", "is not a norms file of this console"),
    (b"{\"a\": NaN}", "is not a JSON norms file"),
    (b"[" * 100000 + b"]" * 100000, "is not a JSON norms file"),
])
def test_what_is_not_json_is_refused(tmp_path, content, words):
    file = tmp_path / "norms.json"
    file.write_bytes(content)
    with pytest.raises(NormsFileError, match=words):
        load_norms(file)


def test_missing_file_and_edited_hash(tmp_path):
    with pytest.raises(NormsFileError, match="no such file"):
        load_norms(tmp_path / "none.json")
    path = write_norms(tmp_path / "n.json", handmade())
    document = json.loads(path.read_text())
    document["figures"]["vgr_reaction_time_s"]["residual_sd"] = 0.2
    path.write_text(json.dumps(document))
    with pytest.raises(NormsFileError, match="does not match its content_sha256"):
        load_norms(path)


def test_writer_refuses_what_the_reader_would(tmp_path):
    with pytest.raises(NormsFileError, match="residual_sd"):
        write_norms(tmp_path / "n.json", _set(handmade(), f"{RT}/residual_sd", -1))
    assert not (tmp_path / "n.json").exists()
    write_norms(tmp_path / "n.json", handmade())
    with pytest.raises(NormsFileError, match="exists"):
        write_norms(tmp_path / "n.json", handmade())


def _as_read(path):
    model = load_norms(path)
    return (model.source, model.simulated, model.covariates, dict(model.figures),
            dict(model.tasks))


def test_corrupted_bytes_are_refused_or_read_the_same(tmp_path):
    """300 corruptions of a written (hashed) file: a byte flipped, replaced, dropped, or the
    file cut short. Each is refused in one line or reads the original's model exactly (a
    change in the spacing); none reads differently in silence, none raises anything else."""
    original = write_norms(tmp_path / "n.json", handmade())
    expected = _as_read(original)
    data = original.read_bytes()
    rng = random.Random(31)
    outcomes = {"refused": 0, "same": 0}
    for i in range(300):
        damaged = bytearray(data)
        kind = i % 4
        at = rng.randrange(len(damaged))
        if kind == 0:
            damaged[at] ^= 1 << rng.randrange(8)
        elif kind == 1:
            damaged[at] = rng.randrange(256)
        elif kind == 2:
            del damaged[at]
        else:
            damaged = damaged[:at]
        path = tmp_path / f"c{i}.json"
        path.write_bytes(bytes(damaged))
        try:
            read = _as_read(path)
        except NormsFileError as exc:
            refusal = str(exc)
        else:
            refusal = None
        if refusal is not None:
            assert "\n" not in refusal
            outcomes["refused"] += 1
            continue
        assert read == expected, f"corruption {i} read differently in silence"
        outcomes["same"] += 1
    assert outcomes["refused"] > 200


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.data())
def test_any_value_anywhere_is_read_or_refused_in_one_line(data):
    """Hypothesis puts arbitrary JSON values at arbitrary places of an unhashed document:
    parse_norms answers with a model or a NormsFileError, never another exception."""
    document = handmade()
    paths = []

    def walk(node, prefix):
        for key, value in (node.items() if isinstance(node, dict) else enumerate(node)):
            here = f"{prefix}/{key}" if prefix else str(key)
            paths.append(here)
            if isinstance(value, dict | list):
                walk(value, here)

    walk(document, "")
    json_values = st.recursive(
        st.none() | st.booleans() | st.integers(-10**20, 10**20)
        | st.floats(allow_nan=False, allow_infinity=False) | st.text(max_size=8),
        lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=5),
                                                                     inner, max_size=3),
        max_leaves=5)
    for _ in range(data.draw(st.integers(1, 3))):
        path = data.draw(st.sampled_from(paths))
        try:
            _set(document, path, data.draw(json_values))
        except (KeyError, IndexError, TypeError, ValueError):
            continue
    refusal = ""
    try:
        parse_norms(document, "fuzz.json")
    except NormsFileError as exc:
        refusal = str(exc)
    if refusal:
        assert "\n" not in refusal
        assert refusal.startswith("norms file fuzz.json: ")


@pytest.mark.parametrize(("block", "key", "shown"), [
    ("figures", "\n", "figures['\\n']"),
    ("tasks", "reach\ning", "tasks['reach\\ning']"),
    ("figures", "x" * 100, "figures['" + "x" * 40 + "'…]"),
    ("figures", "vgr_sparc ", "figures['vgr_sparc ']"),
])
def test_a_key_a_line_cannot_show_is_named_escaped_in_one_line(block, key, shown):
    """CI's fuzz run put {'\\n': None} at `figures`: the refusal named the key as it was and
    came out on two lines."""
    document = handmade()
    document[block] = {key: None}
    with pytest.raises(NormsFileError) as refused:
        parse_norms(document, "fuzz.json")
    message = str(refused.value)
    assert "\n" not in message
    assert f"norms file fuzz.json: {shown}: " in message
