"""The compiled form of a learned model (core.learning.kernel, compiled by numba in
device.compiled) gives the numpy tick's torques (core.learning.tick) to 1e-6, for an FNN
and a DeLaN of each activation, over states across the robot's workspace."""

import numpy as np
import pytest

from core.learning import networks as nw
from core.learning.kernel import learned_torques, pack
from core.learning.tick import TickModel
from device.compiled.jit import compiled

MEAN = [2.6, 1.3, 0.0, 0.0, 0.0, 0.0]
STD = [0.3, 0.25, 0.8, 0.9, 6.0, 7.0]


def model(kind, activation="tanh", hidden=(16, 16), seed=0):
    spec = {"kind": kind, "dof": 2, "hidden": list(hidden), "position_inputs": [0, 1],
            "input_mean": MEAN, "input_std": STD, "output_mean": [0.05, -0.02],
            "output_std": [0.4, 0.3]}
    if kind == "delan":
        spec.update(dissipation_hidden=[8], activation=activation, mass_scale=0.5,
                    potential_scale=0.1, coulomb_speed_fraction=0.01)
    rng = np.random.default_rng(seed)
    params = {k: rng.normal(scale=0.6, size=s) for k, s in nw.param_shapes(spec).items()}
    return spec, params


def states(n=200, seed=1):
    rng = np.random.default_rng(seed)
    return np.column_stack([rng.normal(MEAN[i], 1.5 * STD[i], n) for i in range(6)])


@pytest.mark.parametrize(("kind", "activation"), [("fnn", "tanh"), ("delan", "tanh"),
                                                  ("delan", "softplus")])
def test_the_compiled_model_gives_the_numpy_ticks_torques(kind, activation):
    spec, params = model(kind, activation)
    tick = TickModel(spec, params)
    weights = pack(spec, params)
    fast = compiled(learned_torques)
    for x in states():
        expected = tick.forces(x[:2], x[2:4], x[4:])
        got = fast(weights, *map(float, x))
        assert np.allclose(got, expected, rtol=1e-6, atol=1e-6), (got, expected)
    # interpreted, the same kernel gives the same numbers (the reference flavour)
    x = states(3)[0]
    assert np.allclose(learned_torques(list(weights), *map(float, x)),
                       tick.forces(x[:2], x[2:4], x[4:]), rtol=1e-9, atol=1e-12)


def test_what_the_kernel_does_not_compute_is_refused():
    spec, params = model("fnn")
    with pytest.raises(ValueError, match="both joint angles"):
        pack({**spec, "position_inputs": [1]}, params)
    with pytest.raises(ValueError, match="rnn model has no compiled form"):
        pack({**spec, "kind": "rnn"}, params)
