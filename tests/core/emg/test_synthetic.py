"""Synthetic subjects: the muscle model is exact, and the processing recovers the known
activations from the EMG made of them."""

import math

import numpy as np
import pytest

from core.emg.mvc import mvc_from_contraction
from core.emg.processing import EmgSettings, envelope, on_time_base, rms_envelope
from core.emg.synthetic import (
    MUSCLES,
    Electrodes,
    MuscleModel,
    activation_dynamics,
    activations_from_torques,
    emg_from_excitations,
    excitation_from_activations,
    joint_torques,
    mvc_contraction,
    torques_from_activations,
)
from core.errors import ParameterError

DT = 0.002


def _torques(duration_s=20.0, seed=0):
    """Smooth shoulder and elbow torques of both signs, a few N·m, like a reach."""
    t = np.arange(0.0, duration_s, DT)
    rng = np.random.default_rng(seed)
    phases = rng.uniform(0, 2 * math.pi, 4)
    shoulder = 4.0 * np.sin(2 * math.pi * 0.25 * t + phases[0]) \
        + 1.5 * np.sin(2 * math.pi * 0.6 * t + phases[1])
    elbow = 3.0 * np.sin(2 * math.pi * 0.3 * t + phases[2]) \
        + 1.0 * np.sin(2 * math.pi * 0.8 * t + phases[3])
    return t, np.column_stack((shoulder, elbow))


def test_load_sharing_reproduces_the_torques_exactly():
    _, tau = _torques()
    a = activations_from_torques(tau)
    assert a.shape == (tau.shape[0], 4)
    assert (a >= 0).all()
    assert (a <= 1).all()
    np.testing.assert_allclose(torques_from_activations(a), tau, atol=1e-9)
    # each pair's agonist follows the sign of its joint's torque
    assert (a[tau[:, 1] > 0.5, 0] > a[tau[:, 1] > 0.5, 1]).all()
    assert (a[tau[:, 1] < -0.5, 1] > a[tau[:, 1] < -0.5, 0]).all()


def test_anatomical_torques_from_the_arms_absolute_convention():
    tau_A = np.array([[1.0, 2.0], [-0.5, 0.5]])  # (τ_sh − τ_el, τ_el)
    np.testing.assert_allclose(joint_torques(tau_A), [[3.0, 2.0], [0.0, 0.5]])


def test_excitation_inverts_the_activation_dynamics():
    model = MuscleModel(delay_s=0.0)
    _, tau = _torques(10.0)
    a = activations_from_torques(tau, model)
    u = excitation_from_activations(a, DT, model)
    back = activation_dynamics(u, DT, model)
    np.testing.assert_allclose(back[50:], a[50:], atol=2e-3)


def test_the_electromechanical_delay_puts_the_emg_ahead_of_the_force():
    _, tau = _torques(10.0)
    a = activations_from_torques(tau)
    without = excitation_from_activations(a, DT, MuscleModel(delay_s=0.0))
    delayed = excitation_from_activations(a, DT, MuscleModel(delay_s=0.05))
    np.testing.assert_array_equal(delayed[:-25], without[25:])  # 25 ticks = 0.05 s ahead
    np.testing.assert_array_equal(delayed[-25:], np.repeat(without[-1:], 25, axis=0))


def test_processing_recovers_the_activations_from_the_emg():
    """The whole chain on a synthetic subject: MVC from its contractions, the trial's
    envelope normalised and put on the 2 ms base, against the known excitations."""
    electrodes = Electrodes()
    settings = EmgSettings(mains_hz=electrodes.mains_hz)
    t, tau = _torques(30.0, seed=1)
    u = excitation_from_activations(activations_from_torques(tau), DT)
    _te, emg = emg_from_excitations(u, DT, electrodes, seed=2)
    mvc = []
    for i, muscle in enumerate(MUSCLES):
        _, contraction = mvc_contraction(muscle, electrodes, seed=10 + i)
        result = mvc_from_contraction(contraction[:, i], electrodes.rate_hz, muscle,
                                      settings=settings, full_scale_V=electrodes.full_scale_V)
        assert result.ok, result.reasons
        # max of a windowed RMS: a little above the true RMS at full effort
        assert 1.0 <= result.value_V / electrodes.gain_V[i] <= 1.25
        mvc.append(result.value_V)
    recovered = on_time_base(envelope(emg, electrodes.rate_hz, settings).normalised(mvc), t)
    # the truth seen through the same window: the RMS of the excitation over each window
    truth = on_time_base(rms_envelope(u, 1 / DT, settings.window_s, settings.overlap_s), t)
    good = np.isfinite(recovered).all(axis=1) & np.isfinite(truth).all(axis=1)
    for i in range(4):
        r, s = recovered[good, i], truth[good, i]
        assert np.corrcoef(r, s)[0, 1] > 0.95, MUSCLES[i]
        # crosstalk adds a little of the neighbours, the MVC's maximum takes a little off
        assert np.sqrt(np.mean((r - s) ** 2)) < 0.06, MUSCLES[i]


def test_a_bad_mvc_inflates_the_normalised_activity():
    electrodes = Electrodes().with_bad_mvc("anterior_deltoid", 0.4)
    i = MUSCLES.index("anterior_deltoid")
    _, good = mvc_contraction("anterior_deltoid", Electrodes(), seed=3)
    _, bad = mvc_contraction("anterior_deltoid", electrodes, seed=3)
    ratio = (mvc_from_contraction(good[:, i], electrodes.rate_hz, "d").value_V
             / mvc_from_contraction(bad[:, i], electrodes.rate_hz, "d").value_V)
    assert ratio == pytest.approx(2.5, rel=0.1)


def test_the_amplifier_clips_at_full_scale():
    electrodes = Electrodes(gain_V=(0.02, 0.8e-3, 0.9e-3, 0.7e-3))
    _, emg = mvc_contraction("biceps", electrodes)
    assert np.abs(emg).max() == pytest.approx(electrodes.full_scale_V)


@pytest.mark.parametrize(("make", "field"), [
    (lambda: MuscleModel(moment_arms_m=((0.0, 0.0),) * 4), "moment_arms_m"),
    (lambda: MuscleModel(max_force_N=(1.0, 2.0)), "max_force_N"),
    (lambda: MuscleModel(cocontraction=0.9), "cocontraction"),
    (lambda: Electrodes(gain_V=(0.0, 1e-3, 1e-3, 1e-3)), "gain_V"),
    (lambda: Electrodes(crosstalk=((0.0,) * 3,) * 3), "crosstalk"),
    (lambda: Electrodes(bad_mvc=(0.0, 1.0, 1.0, 1.0)), "bad_mvc"),
    (lambda: activations_from_torques(np.zeros((5, 3))), "torques_Nm"),
    (lambda: emg_from_excitations(np.zeros((5, 3)), DT), "excitation"),
])
def test_bad_models_are_refused(make, field):
    with pytest.raises(ParameterError, match=field):
        make()


def test_the_stream_makes_the_emg_as_the_torques_come_causally_and_without_seams():
    """EmgStream (the live synthetic source): fed in stretches of 31 ticks, its EMG is one
    evenly sampled signal up to the newest torque less the delay, and its envelope is the
    batch generator's to within the noise: the same activations behind it."""
    from core.emg.synthetic import EmgStream, absolute_torques

    t, torques = _torques(12.0)
    model, electrodes = MuscleModel(), Electrodes()
    stream = EmgStream(model, electrodes, DT, seed=3)
    times, samples = [], []
    for i in range(0, t.size, 31):
        ts, x = stream.push(t[i:i + 31], torques[i:i + 31])
        if ts.size:
            # what a stretch releases runs the electromechanical delay behind its torque
            assert ts[-1] <= t[min(i + 30, t.size - 1)] - model.delay_s + 1e-12
        times.append(ts)
        samples.append(x)
    ts, x = np.concatenate(times), np.vstack(samples)
    step = np.diff(ts)
    assert step == pytest.approx(np.full(step.size, 1.0 / electrodes.rate_hz), rel=1e-9)
    assert ts[0] == 0.0
    batch_t, batch = emg_from_excitations(excitation_from_activations(
        activations_from_torques(torques, model), DT, model), DT, electrodes, seed=3)
    streamed = envelope(x, electrodes.rate_hz, t0_s=ts[0])
    made = envelope(batch, electrodes.rate_hz, t0_s=batch_t[0])
    inside = (made.t_s > 1.0) & (made.t_s < ts[-1] - 0.2)
    a = np.column_stack([np.interp(made.t_s[inside], streamed.t_s, streamed.values[:, j])
                         for j in range(4)])
    b = made.values[inside]
    # the same envelope to within the noise of two different draws
    assert np.corrcoef(a[:, 0], b[:, 0])[0, 1] > 0.9
    assert np.median(np.abs(a - b) / np.maximum(b, 1e-6)) < 0.2
    # absolute_torques is joint_torques' inverse
    assert absolute_torques(joint_torques(torques)) == pytest.approx(torques)
