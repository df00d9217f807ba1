"""The sliding inverted pendulum's data (thesis eq. 2.36–2.39) against the equations."""

import numpy as np
import pytest

from core.errors import ParameterError
from core.learning import pendulum as pd

G = 9.81


@pytest.fixture(scope="module")
def thesis_data():
    return pd.generate()


def test_thesis_size_and_held_out_cycle(thesis_data):
    d = thesis_data
    assert d.q.shape == d.qd.shape == d.qdd.shape == d.tau.shape == (101_000, 2)
    assert np.unique(d.cycle).size == 1000
    test = pd.held_out_mask(d)
    assert test.sum() == 101  # 100,899 training samples and one cycle, as Table 2.1
    np.testing.assert_array_equal(d.qd[test, 1], 5.0)


def test_rod_driven_at_constant_speed_from_minus_to_plus_45_degrees(thesis_data):
    d = thesis_data
    theta = d.q[:, 1].reshape(1000, 101)
    np.testing.assert_allclose(theta[:, 0], -np.pi / 4, rtol=0, atol=1e-15)
    np.testing.assert_allclose(theta[:, -1], np.pi / 4, rtol=0, atol=1e-15)
    np.testing.assert_array_equal(d.qdd[:, 1], 0.0)  # eq. 2.37–2.38: θ̈2 = 0
    speeds = d.qd[:, 1].reshape(1000, 101)
    np.testing.assert_array_equal(speeds, np.broadcast_to(speeds[:, :1], speeds.shape))
    np.testing.assert_allclose(speeds[:, 0], d.speeds_rad_s)


def test_generator_satisfies_eq_2_36_to_rounding(thesis_data):
    """Both rows of eq. 2.36, written out here from the thesis, with f from eq. 2.39."""
    d = thesis_data
    M, m, L, mu = 1.0, 10.0, 1.0, 0.6
    x_dd, th, th_d, th_dd = d.qdd[:, 0], d.q[:, 1], d.qd[:, 1], d.qdd[:, 1]
    row1 = (m + M) * x_dd + m * L / 2 * np.cos(th) * th_dd - m * L / 2 * th_d**2 * np.sin(th)
    row2 = m * L / 2 * np.cos(th) * x_dd + m * L**2 / 3 * th_dd - m * G * L / 2 * np.sin(th)
    scale = np.abs(d.tau).max(axis=0)
    np.testing.assert_allclose(row1, d.tau[:, 0], rtol=0, atol=1e-14 * scale[0] * 10)
    np.testing.assert_allclose(row2, d.tau[:, 1], rtol=0, atol=1e-14 * scale[1] * 10)
    # eq. 2.39, f = μ g (M + m L/2 cos θ2)
    np.testing.assert_allclose(d.tau[:, 0], mu * G * (M + m * L / 2 * np.cos(th)), rtol=1e-15)


def test_model_terms_give_the_same_forces(thesis_data):
    d = thesis_data
    forces = pd.Pendulum().generalised_forces(d.q, d.qd, d.qdd)
    np.testing.assert_allclose(forces, d.tau, rtol=0, atol=1e-12)


def test_base_integrated_by_backward_euler_from_rest():
    d = pd.generate([2.0, 7.0])
    for c, speed in enumerate([2.0, 7.0]):
        rows = d.cycle == c
        h = (np.pi / 2) / 100 / speed
        x, x_d, x_dd = d.q[rows, 0], d.qd[rows, 0], d.qdd[rows, 0]
        assert x[0] == 0.0
        assert x_d[0] == 0.0
        np.testing.assert_allclose(np.diff(x_d), h * x_dd[1:], rtol=1e-12, atol=1e-15)
        np.testing.assert_allclose(np.diff(x), h * x_d[1:], rtol=1e-12, atol=1e-15)


def test_mass_matrix_is_symmetric_positive_definite():
    H = pd.Pendulum().mass_matrix(np.linspace(-np.pi, np.pi, 50))
    np.testing.assert_array_equal(H, np.swapaxes(H, -1, -2))
    assert np.all(np.linalg.eigvalsh(H) > 0)


@pytest.mark.parametrize("speeds", [[], [1.0, -2.0], [np.nan], [0.0]])
def test_bad_speeds_refused(speeds):
    with pytest.raises(ValueError, match="speeds"):
        pd.generate(speeds)


def test_bad_pendulum_refused():
    with pytest.raises(ParameterError, match="rod_mass_kg"):
        pd.Pendulum(rod_mass_kg=0.0)


def test_held_out_speed_must_be_a_cycle():
    with pytest.raises(ValueError, match=r"no cycle at 5\.5"):
        pd.held_out_mask(pd.generate([1.0, 2.0]), 5.5)


def test_speeds_that_fling_or_run_away_the_base_are_refused():
    """The base's top speed (from the samples) bounds the rod's speeds on both sides: the
    friction's push over a slow sweep, the swing at a fast one."""
    low, high = pd.speed_limits()
    for speed in (low, high):
        top = pd.base_top_speeds(pd.generate([speed]))[0]
        assert top == pytest.approx(pd.MAX_BASE_SPEED_M_S, rel=1e-6)
    assert 0.4 < low < 1.0  # the thesis's 1 … 10 inside
    assert 10.0 < high < 100.0
    for speed in (low * 0.99, high * 1.01, 1e9, 1e200):
        with pytest.raises(ParameterError, match="the base would slide at"):
            pd.generate([3.0, speed])
        assert pd.speed_refusal(speed).startswith(f"at {speed:g} rad/s")
    assert pd.speed_refusal(low * 1.01) == pd.speed_refusal(high * 0.99) == ""
    assert np.all(pd.base_top_speeds(pd.generate()) < 5.0)
