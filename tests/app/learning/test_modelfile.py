"""A model file keeps what it needs, and a wrong one is refused by the fault's name."""

import json

import numpy as np
import pytest

from app.learning.dataset import Dataset
from app.learning.modelfile import ModelFileError, content_hash, read_model, write_model
from app.records import signing
from core.learning import inference, networks as nw

SPEC = {"kind": "fnn", "dof": 2, "hidden": [5], "position_inputs": [0, 1],
        "input_mean": [0.0] * 6, "input_std": [1.0] * 6, "output_mean": [0.0, 0.0],
        "output_std": [1.0, 2.0]}
DATA = {"system": "sliding-inverted-pendulum", "dof": 2, "forces": ["f", "tau"]}


@pytest.fixture
def model_path(tmp_path):
    params = nw.init_params(SPEC, 3)
    params["net.0.b"] = np.array([0.1, -1 / 3, 1e-300, np.pi, 7.0])
    return write_model(tmp_path / "m.json", "m", SPEC, params, DATA, {"epochs": 3},
                       {"rmse": 1.0})


def edit(path, change, rehash=False):
    """Change the file; `rehash`: its hash recomputed and signed by this installation, as
    if the console had written it so (what else the reader checks)."""
    document = json.loads(path.read_text())
    change(document)
    if rehash:
        document["content_sha256"] = content_hash(document)
        document = signing.sign(document)
    path.write_text(json.dumps(document))


def test_round_trip_is_exact(model_path):
    model = read_model(model_path)
    params = nw.init_params(SPEC, 3)
    params["net.0.b"] = np.array([0.1, -1 / 3, 1e-300, np.pi, 7.0])
    for name, value in params.items():
        np.testing.assert_array_equal(model.params[name], value)
    assert model.parameters == 6 * 5 + 5 + 5 * 2 + 2
    assert model.data["system"] == "sliding-inverted-pendulum"
    assert model.hyper_parameters == {"epochs": 3}
    assert {"python", "numpy", "jax", "jaxlib", "optax"} <= model.software.keys()
    assert model.software["jax"] == "0.10.2"
    x = np.ones((3, 2))
    np.testing.assert_array_equal(inference.predict(model.spec, model.params, x, x, x),
                                  inference.predict(SPEC, params, x, x, x))


def test_edited_weight_refused_by_content_hash(model_path):
    edit(model_path, lambda d: d["weights"]["net.0.b"]["values"].__setitem__(0, 0.2))
    with pytest.raises(ModelFileError, match="content hash") as caught:
        read_model(model_path)
    assert caught.value.reason == "content hash"


def test_edited_metrics_refused_by_content_hash(model_path):
    edit(model_path, lambda d: d["metrics"].__setitem__("rmse", 0.01))
    with pytest.raises(ModelFileError, match="content hash"):
        read_model(model_path)


def test_weights_that_do_not_fit_refused_by_input_size(model_path):
    """Rehashed after the edit, so only the sizes are wrong."""
    def grow(d):
        d["model"]["dof"] = 3
    edit(model_path, grow, rehash=True)
    with pytest.raises(ModelFileError, match=r"input size: weights net\.0\.W") as caught:
        read_model(model_path)
    assert caught.value.reason == "input size"


def data(system="sliding-inverted-pendulum", dof=2):
    a = np.zeros((4, dof))
    return Dataset(a, a, a, a, np.zeros(4, int), system, tuple("ab"[:dof]) if dof <= 2
                   else ("a", "b", "c"), ("f", "tau", "x")[:dof])


def test_data_of_another_system_refused_by_system(model_path):
    model = read_model(model_path)
    model.check_data(data())
    with pytest.raises(ModelFileError, match="system: the model was trained on "
                       "'sliding-inverted-pendulum', the data are from 'robot'") as caught:
        model.check_data(data("robot"))
    assert caught.value.reason == "system"


def test_data_of_another_size_refused_by_input_size(model_path):
    with pytest.raises(ModelFileError, match="input size: the model takes 2 coordinates, "
                       "the data have 3"):
        read_model(model_path).check_data(data(dof=3))


@pytest.mark.parametrize(("content", "message"), [
    ("not json", "is not a JSON model file"),
    ('{"format": "something-else"}', "is not a model file of this console"),
    ('[1, 2]', "is not a model file of this console"),
])
def test_not_a_model_file_refused(tmp_path, content, message):
    (tmp_path / "x.json").write_text(content)
    with pytest.raises(ModelFileError, match=message):
        read_model(tmp_path / "x.json")


def test_missing_refused(tmp_path):
    with pytest.raises(ModelFileError, match="missing: no such file"):
        read_model(tmp_path / "none.json")


def test_newer_format_refused(model_path):
    edit(model_path, lambda d: d.__setitem__("format_version", 2), rehash=True)
    with pytest.raises(ModelFileError, match="format version 2, newer"):
        read_model(model_path)


def test_incomplete_weights_refused(model_path):
    edit(model_path, lambda d: d["weights"].pop("net.1.W"), rehash=True)
    with pytest.raises(ModelFileError, match=r"input size: weights net\.1\.W"):
        read_model(model_path)
