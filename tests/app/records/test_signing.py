"""Issue 28 #11: the files that decide what drives the robot cannot be re-signed by editing.

Before: a learned model or an EMG approval edited and its content_sha256 recomputed was
accepted as the console's own; a model with a weight of 1e308 evaluated to RMSE inf with
exit 0; a model copied under a new name, as the README suggests, was refused."""

from __future__ import annotations

import json
import os
import shutil
import stat

import numpy as np
import pytest

from app.learning.library import inverse_dynamics, robot_model
from app.learning.modelfile import ModelFileError, content_hash, read_model, write_model
from core.learning import networks as nw
from core.trial import THESIS_SUBJECT
from device.loop.pipeline import learned_model_refusal

ROBOT_DATA = {"system": "rehab-robot-simulator", "dof": 2}
SPEC = {"kind": "fnn", "dof": 2, "hidden": [3], "position_inputs": [0, 1],
        "input_mean": [0.0] * 6, "input_std": [1.0] * 6, "output_mean": [0.0] * 2,
        "output_std": [1.0] * 2}


@pytest.fixture
def config(tmp_path, monkeypatch):
    """This test's installation: a config folder of its own, so a key of its own."""
    folder = tmp_path / "config"
    monkeypatch.setenv("REHAB_CONFIG_DIR", str(folder))
    return folder


def model(folder, name="fnn-robot", weights=None):
    params = {k: np.random.default_rng(0).normal(size=s)
              for k, s in nw.param_shapes(SPEC).items()}
    params.update(weights or {})
    folder.mkdir(parents=True, exist_ok=True)
    return write_model(folder / f"{name}.json", name, SPEC, params, ROBOT_DATA, {}, {})


def rehashed(path, change):
    """The file edited and its content hash recomputed, as the issue's attack did."""
    document = json.loads(path.read_text())
    change(document)
    document["content_sha256"] = content_hash(document)
    path.write_text(json.dumps(document))


def test_an_edited_and_rehashed_model_is_refused_by_its_signature(config, tmp_path):
    path = model(tmp_path / "models")
    read_model(path)
    rehashed(path, lambda d: d["weights"]["net.0.b"]["values"].__setitem__(0, 3.0))
    with pytest.raises(ModelFileError, match="signature: it was changed after it was "
                                             "signed") as caught:
        read_model(path)
    assert caught.value.reason == "signature"
    assert "rehab models import" in str(caught.value)


def test_a_model_from_another_installation_is_refused_until_imported(config, tmp_path,
                                                                     monkeypatch):
    path = model(tmp_path / "models")
    monkeypatch.setenv("REHAB_CONFIG_DIR", str(tmp_path / "elsewhere"))
    with pytest.raises(ModelFileError, match="signed by another installation"):
        read_model(path)


def test_a_weight_no_trained_model_has_is_refused_even_signed_here(config, tmp_path):
    """A weight of 1e308 made every torque inf and `rehab learn evaluate` print RMSE inf."""
    path = model(tmp_path / "models", weights={"net.0.b": np.array([1e308, 0.0, 0.0])})
    with pytest.raises(ModelFileError, match=r"weights: its weights hold 1e\+308") as caught:
        read_model(path)
    assert caught.value.reason == "weights"


def test_a_model_copied_under_a_new_name_drives_a_trial_by_that_name(config, tmp_path):
    folder = tmp_path / "models"
    model(folder)
    shutil.copy(folder / "fnn-robot.json", folder / "mine.json")  # as the README says
    mine = robot_model(folder, "mine")
    assert mine.name == "mine"
    params = THESIS_SUBJECT.replace(controller="ctpid", learned_model="mine",
                                    learned_model_sha256=mine.content_sha256)
    assert learned_model_refusal(params, inverse_dynamics(mine)) == ""


# -- the key ------------------------------------------------------------------------------------


def test_the_key_is_made_private_and_kept(config):
    from app.records import signing

    key = signing.installation_key()
    path = config / signing.KEY_NAME
    assert stat.S_IMODE(path.stat().st_mode) == 0o600
    assert stat.S_IMODE(config.stat().st_mode) == 0o700
    signing._cache.clear()
    assert signing.installation_key() == key  # read back, not made again


@pytest.mark.skipif(os.name != "posix", reason="POSIX file modes")
def test_a_key_others_could_read_or_replace_is_refused_in_one_line(config):
    from app.records import signing

    signing.installation_key()
    path = config / signing.KEY_NAME
    signing._cache.clear()
    path.chmod(0o644)
    with pytest.raises(signing.SigningError, match="can be read by others") as caught:
        signing.installation_key()
    assert "chmod 600" in str(caught.value)
    assert "\n" not in str(caught.value)
    path.chmod(0o600)
    config.chmod(0o777)
    with pytest.raises(signing.SigningError, match="can be written by others"):
        signing.installation_key()
    config.chmod(0o700)
    path.unlink()
    path.symlink_to(config / "elsewhere.key")
    with pytest.raises(signing.SigningError, match="not a link"):
        signing.installation_key()
