"""Synthetic surface EMG from known muscle activations, for the tests and the models.

A subject's shoulder and elbow torques (anatomical joints, N·m, e.g. a virtual
patient's) are shared among four muscles by a simple muscle model, which gives
each muscle's activation; the activation becomes an excitation (what EMG
measures) by inverting first-order activation dynamics and advancing by the
electromechanical delay; the excitation modulates band-limited Gaussian noise,
the classical model of the surface EMG interference pattern (amplitude-modulated
noise, e.g. Hogan & Mann 1980); crosstalk between electrodes, an amplifier noise
floor, mains interference and the amplifier's full scale are added. Every number is
an order-of-magnitude choice, not an identified value.

Muscles: biceps brachii (elbow flexor, small shoulder flexor moment), triceps
brachii (elbow extensor; its long head extends the shoulder), anterior deltoid
(shoulder flexor, horizontal adduction in the table plane) and posterior deltoid
(shoulder extensor). The thesis recorded the first three (`THESIS_MUSCLES`):
without the posterior deltoid, a shoulder extension is seen only through the
triceps, one of the reasons a model from those three cannot recover the shoulder
torque (section 5.2.2).

Load sharing (`activations_from_torques`), exact: the elbow torque is taken by
biceps (flexion) or triceps (extension), over a co-contraction of both that adds
no net elbow torque; the shoulder torque that the two biarticular muscles leave
is taken by the anterior (flexion) or posterior (extension) deltoid, over their
own co-contraction. `torques_from_activations` is the inverse: τ = Rᵀ (a ∘ F_max).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from core.errors import ParameterError, check_positive, check_range

MUSCLES = ("biceps", "triceps", "anterior_deltoid", "posterior_deltoid")
THESIS_MUSCLES = MUSCLES[:3]
BICEPS, TRICEPS, ANTERIOR_DELTOID, POSTERIOR_DELTOID = range(4)
TRIGNO_RATE_HZ = 1925.926  # Delsys Trigno EMG sampling rate
TRIGNO_FULL_SCALE_V = 0.011  # ±11 mV


@dataclass(frozen=True, slots=True)
class MuscleModel:
    """Moment arms (m) about (shoulder, elbow), positive for flexion, maximal forces (N),
    co-contraction (fraction of MVC held by each pair), activation time constants (s)
    and the electromechanical delay (s)."""

    moment_arms_m: tuple[tuple[float, float], ...] = (
        (0.015, 0.035),   # biceps
        (-0.015, -0.025),  # triceps
        (0.030, 0.0),      # anterior deltoid
        (-0.030, 0.0),     # posterior deltoid
    )
    max_force_N: tuple[float, ...] = (600.0, 800.0, 700.0, 500.0)
    cocontraction: float = 0.03
    activation_tau_s: float = 0.015
    deactivation_tau_s: float = 0.050
    delay_s: float = 0.040

    def __post_init__(self) -> None:
        arms = np.asarray(self.moment_arms_m, dtype=float)
        if arms.shape != (len(MUSCLES), 2):
            raise ParameterError("moment_arms_m", arms.shape, f"({len(MUSCLES)}, 2)")
        if arms[BICEPS, 1] <= 0 or arms[TRICEPS, 1] >= 0 or arms[ANTERIOR_DELTOID, 0] <= 0 \
                or arms[POSTERIOR_DELTOID, 0] >= 0:
            raise ParameterError("moment_arms_m", self.moment_arms_m,
                                 "flexors positive, extensors negative")
        if len(self.max_force_N) != len(MUSCLES) or min(self.max_force_N) <= 0:
            raise ParameterError("max_force_N", self.max_force_N, "four forces > 0 N")
        check_range("cocontraction", self.cocontraction, 0.0, 0.5)
        check_positive("activation_tau_s", self.activation_tau_s, "s")
        check_positive("deactivation_tau_s", self.deactivation_tau_s, "s")
        check_range("delay_s", self.delay_s, 0.0, 0.2, "s")

    @property
    def arms(self) -> np.ndarray:
        return np.asarray(self.moment_arms_m, dtype=float)

    @property
    def forces(self) -> np.ndarray:
        return np.asarray(self.max_force_N, dtype=float)


def joint_torques(tau_A) -> np.ndarray:
    """Anatomical (shoulder, elbow) torques from the arm's τ_A in absolute angles
    (device.sim.patients: τ_A = (τ_sh − τ_el, τ_el), so τ_sh = τ_A0 + τ_A1)."""
    t = np.asarray(tau_A, dtype=float)
    return np.stack((t[..., 0] + t[..., 1], t[..., 1]), axis=-1)


def absolute_torques(torques_Nm) -> np.ndarray:
    """The arm's τ_A in absolute angles from anatomical (shoulder, elbow) torques: the
    inverse of `joint_torques`, τ_A = (τ_sh − τ_el, τ_el)."""
    t = np.asarray(torques_Nm, dtype=float)
    return np.stack((t[..., 0] - t[..., 1], t[..., 1]), axis=-1)


def activations_from_torques(torques_Nm, model: MuscleModel | None = None) -> np.ndarray:
    """Activations (N, 4), in [0, 1], that produce the anatomical torques (N, 2) exactly
    (module docstring); activations above 1 are clipped (the torque asked exceeds the
    model's muscles) and then no longer produce it."""
    model = model or MuscleModel()
    tau = np.asarray(torques_Nm, dtype=float)
    if tau.ndim != 2 or tau.shape[1] != 2:
        raise ParameterError("torques_Nm", f"an array of shape {tau.shape}", "shape (N, 2)")
    R, F = model.arms, model.forces
    a = np.zeros((tau.shape[0], len(MUSCLES)))
    c = model.cocontraction
    # elbow pair: biceps co-contraction c, triceps the same torque back
    flex_b, ext_t = R[BICEPS, 1] * F[BICEPS], -R[TRICEPS, 1] * F[TRICEPS]
    a[:, BICEPS] = c + np.maximum(tau[:, 1], 0.0) / flex_b
    a[:, TRICEPS] = c * flex_b / ext_t + np.maximum(-tau[:, 1], 0.0) / ext_t
    shoulder_left = tau[:, 0] - a[:, BICEPS] * F[BICEPS] * R[BICEPS, 0] \
        - a[:, TRICEPS] * F[TRICEPS] * R[TRICEPS, 0]
    flex_a, ext_p = R[ANTERIOR_DELTOID, 0] * F[ANTERIOR_DELTOID], \
        -R[POSTERIOR_DELTOID, 0] * F[POSTERIOR_DELTOID]
    a[:, ANTERIOR_DELTOID] = c + np.maximum(shoulder_left, 0.0) / flex_a
    a[:, POSTERIOR_DELTOID] = c * flex_a / ext_p + np.maximum(-shoulder_left, 0.0) / ext_p
    return np.clip(a, 0.0, 1.0)


def torques_from_activations(activations, model: MuscleModel | None = None) -> np.ndarray:
    """Anatomical (shoulder, elbow) torques (N, 2) of activations (N, 4): Rᵀ (a ∘ F_max)."""
    model = model or MuscleModel()
    a = np.asarray(activations, dtype=float)
    return (a * model.forces) @ model.arms


def activation_dynamics(excitation, dt_s: float, model: MuscleModel | None = None) -> np.ndarray:
    """Activation from excitation, da/dt = (u − a)/τ with τ the activation time constant
    while a rises and the deactivation one while it falls (Zajac 1989, first order),
    integrated exactly per step."""
    model = model or MuscleModel()
    u = np.asarray(excitation, dtype=float)
    a = np.empty_like(u)
    rise = np.exp(-dt_s / model.activation_tau_s)
    fall = np.exp(-dt_s / model.deactivation_tau_s)
    state = u[0].copy()
    for k in range(u.shape[0]):
        decay = np.where(u[k] > state, rise, fall)
        state = u[k] + (state - u[k]) * decay
        a[k] = state
    return a


def excitation_from_activations(activations, dt_s: float,
                                model: MuscleModel | None = None) -> np.ndarray:
    """The excitation that leads to `activations`: u = a + τ(u, a)·da/dt (first order,
    inverted), advanced by the electromechanical delay (EMG leads the force), in [0, 1].
    The last `delay_s` repeat the last value."""
    model = model or MuscleModel()
    a = np.asarray(activations, dtype=float)
    rate = np.gradient(a, dt_s, axis=0)
    tau = np.where(rate > 0.0, model.activation_tau_s, model.deactivation_tau_s)
    u = np.clip(a + tau * rate, 0.0, 1.0)
    shift = round(model.delay_s / dt_s)
    if shift:
        u = np.concatenate((u[shift:], np.repeat(u[-1:], shift, axis=0)))
    return u


@dataclass(frozen=True, slots=True)
class Electrodes:
    """How the excitations become recorded EMG.

    `gain_V`: RMS EMG of each muscle at full excitation (a few hundred µV to a few
    mV on the skin). `crosstalk[i][j]`: share of muscle j's signal picked up by
    electrode i (i ≠ j). `bad_mvc`: per muscle, the share of a maximal effort the
    subject gives in the MVC recording (1 = a true maximum; subject 2's deltoid
    was perhaps 0.4)."""

    rate_hz: float = TRIGNO_RATE_HZ
    gain_V: tuple[float, ...] = (1.0e-3, 0.8e-3, 0.9e-3, 0.7e-3)
    crosstalk: tuple[tuple[float, ...], ...] = (
        (0.0, 0.10, 0.05, 0.0),
        (0.10, 0.0, 0.0, 0.08),
        (0.05, 0.0, 0.0, 0.10),
        (0.0, 0.08, 0.10, 0.0),
    )
    noise_V: float = 5.0e-6
    mains_V: float = 10.0e-6
    mains_hz: float = 50.0
    full_scale_V: float = TRIGNO_FULL_SCALE_V
    band_hz: tuple[float, float] = (20.0, 450.0)
    bad_mvc: tuple[float, ...] = field(default=(1.0, 1.0, 1.0, 1.0))

    def __post_init__(self) -> None:
        check_positive("rate_hz", self.rate_hz, "Hz")
        if len(self.gain_V) != len(MUSCLES) or min(self.gain_V) <= 0:
            raise ParameterError("gain_V", self.gain_V, "four gains > 0 V")
        x = np.asarray(self.crosstalk, dtype=float)
        if x.shape != (len(MUSCLES),) * 2 or (x < 0).any() or (x > 0.5).any():
            raise ParameterError("crosstalk", self.crosstalk, "4×4 shares in [0, 0.5]")
        if len(self.bad_mvc) != len(MUSCLES) or not all(0 < b <= 1 for b in self.bad_mvc):
            raise ParameterError("bad_mvc", self.bad_mvc, "four shares in (0, 1]")

    def mixing(self) -> np.ndarray:
        """Electrode i's signal = Σ_j M[i, j] · muscle j's, M = I + crosstalk."""
        m = np.asarray(self.crosstalk, dtype=float).copy()
        np.fill_diagonal(m, 1.0)
        return m

    def with_bad_mvc(self, muscle: str, share: float) -> Electrodes:
        shares = list(self.bad_mvc)
        shares[MUSCLES.index(muscle)] = share
        return _replace(self, bad_mvc=tuple(shares))


def _replace(electrodes: Electrodes, **changes) -> Electrodes:
    from dataclasses import replace

    return replace(electrodes, **changes)


def _carrier_filter(rate_hz: float, band_hz):
    from scipy.signal import butter

    return butter(4, band_hz, btype="bandpass", output="sos", fs=rate_hz)


def _carrier(n: int, rate_hz: float, band_hz, rng: np.random.Generator, width: int) -> np.ndarray:
    """Unit-RMS Gaussian noise band-limited to `band_hz` (the interference pattern)."""
    from scipy.signal import sosfilt

    lead = round(0.5 * rate_hz)  # the filter's start-up, discarded
    noise = sosfilt(_carrier_filter(rate_hz, band_hz), rng.standard_normal((n + lead, width)),
                    axis=0)[lead:]
    return noise / noise.std(axis=0)


def _recorded(level, carrier, t, electrodes: Electrodes, noise, phase) -> np.ndarray:
    """What the electrodes record (V) of excitation `level` (M, 4) on unit `carrier`
    noise at times `t`: each muscle's signal at its gain, mixed by the crosstalk, plus
    the amplifier's `noise` (unit normal, (M, 4)) and the mains at `phase`, clipped at
    the amplifier's full scale."""
    sources = level * np.asarray(electrodes.gain_V) * carrier
    emg = sources @ electrodes.mixing().T
    emg += electrodes.noise_V * noise
    emg += electrodes.mains_V * np.sin(2.0 * np.pi * electrodes.mains_hz * t[:, None] + phase)
    return np.clip(emg, -electrodes.full_scale_V, electrodes.full_scale_V)


def emg_from_excitations(
    excitation,
    dt_s: float,
    electrodes: Electrodes | None = None,
    *,
    seed: int = 0,
    t0_s: float = 0.0,
) -> tuple[np.ndarray, np.ndarray]:
    """Recorded EMG (M, 4) in V at `electrodes.rate_hz`, and its times (M,), from the
    excitations (N, 4) sampled every `dt_s` from `t0_s`."""
    electrodes = electrodes or Electrodes()
    u = np.asarray(excitation, dtype=float)
    if u.ndim != 2 or u.shape[1] != len(MUSCLES):
        raise ParameterError("excitation", f"an array of shape {u.shape}",
                             f"shape (N, {len(MUSCLES)})")
    rng = np.random.default_rng(seed)
    duration = (u.shape[0] - 1) * dt_s
    t = t0_s + np.arange(int(np.floor(duration * electrodes.rate_hz)) + 1) / electrodes.rate_hz
    grid = t0_s + np.arange(u.shape[0]) * dt_s
    level = np.column_stack([np.interp(t, grid, u[:, j]) for j in range(len(MUSCLES))])
    carrier = _carrier(t.size, electrodes.rate_hz, electrodes.band_hz, rng, len(MUSCLES))
    noise = rng.standard_normal((t.size, len(MUSCLES)))
    phase = rng.uniform(0.0, 2.0 * np.pi, len(MUSCLES))
    return t, _recorded(level, carrier, t, electrodes, noise, phase)


class EmgStream:
    """Synthetic EMG made while the torques come, as a live source gives it: `push` takes
    each new stretch of a subject's anatomical torques (ticks `dt_s` apart) and returns
    the EMG it lets the stream record.

    The same model as `emg_from_excitations` after `excitation_from_activations`, made
    causal: the excitation's rate is a backward difference; the band-pass of the carrier
    keeps its state from stretch to stretch (so the EMG has no seams) and is scaled to
    unit RMS by the filter's own noise gain; and since EMG leads the force by the
    electromechanical delay, the EMG of time t is known once the torque of t + delay is,
    so what `push` returns runs `delay_s` behind the newest torque."""

    def __init__(self, model: MuscleModel, electrodes: Electrodes, dt_s: float, *,
                 seed: int = 0, t0_s: float = 0.0) -> None:
        from scipy.signal import sosfilt, sosfilt_zi

        self.model, self.electrodes = model, electrodes
        self.dt_s = check_positive("dt_s", dt_s, "s")
        self._rng = np.random.default_rng(seed)
        width = len(MUSCLES)
        self._sos = _carrier_filter(electrodes.rate_hz, electrodes.band_hz)
        self._zi = np.repeat(sosfilt_zi(self._sos)[:, :, None], width, axis=2) * 0.0
        # the filter's RMS gain on unit white noise, measured once on a long stretch
        probe = sosfilt(self._sos, np.random.default_rng(0).standard_normal(200_000))
        self._gain = float(probe[round(0.5 * electrodes.rate_hz):].std())
        self._phase = self._rng.uniform(0.0, 2.0 * np.pi, width)
        self._last: np.ndarray | None = None  # the activation before this stretch
        self._grid_t = np.empty(0)
        self._grid_u = np.empty((0, width))
        self._next = 0  # the next EMG sample's index from t0
        self.t0_s = float(t0_s)

    def push(self, t_s, torques_Nm) -> tuple[np.ndarray, np.ndarray]:
        """The EMG (K, 4) and its times (K,) that the torques (N, 2) at times t_s (N,)
        release: every EMG sample up to the newest torque's time less the delay."""
        from scipy.signal import sosfilt

        t = np.asarray(t_s, dtype=float)
        a = activations_from_torques(np.nan_to_num(torques_Nm), self.model)
        if t.size == 0:
            return np.empty(0), np.empty((0, len(MUSCLES)))
        before = self._last if self._last is not None else a[0]
        rate = np.diff(np.vstack((before, a)), axis=0) / self.dt_s
        tau = np.where(rate > 0.0, self.model.activation_tau_s, self.model.deactivation_tau_s)
        u = np.clip(a + tau * rate, 0.0, 1.0)
        self._last = a[-1].copy()
        # the excitation of time t drives the force of t + delay: stamp it earlier
        self._grid_t = np.concatenate((self._grid_t[-1:], t - self.model.delay_s))
        self._grid_u = np.vstack((self._grid_u[-1:], u))
        rate_hz = self.electrodes.rate_hz
        last = int(np.floor((self._grid_t[-1] - self.t0_s) * rate_hz))
        k = np.arange(max(self._next, int(np.ceil((self._grid_t[0] - self.t0_s) * rate_hz))),
                      last + 1)
        self._next = last + 1
        times = self.t0_s + k / rate_hz
        width = len(MUSCLES)
        level = np.column_stack([np.interp(times, self._grid_t, self._grid_u[:, j])
                                 for j in range(width)])
        carrier, self._zi = sosfilt(self._sos, self._rng.standard_normal((k.size, width)),
                                    axis=0, zi=self._zi)
        noise = self._rng.standard_normal((k.size, width))
        return times, _recorded(level, carrier / self._gain, times, self.electrodes, noise,
                                self._phase)


def mvc_contraction(
    muscle: str,
    electrodes: Electrodes | None = None,
    *,
    hold_s: float = 3.0,
    rest_s: float = 1.0,
    seed: int = 0,
) -> tuple[np.ndarray, np.ndarray]:
    """The EMG (M, 4) and times of an isometric MVC of one muscle: rest, a ramp of
    0.3 s to the effort the subject gives (`electrodes.bad_mvc`, 1 for a true
    maximum), held for `hold_s`, back to rest."""
    electrodes = electrodes or Electrodes()
    index = MUSCLES.index(muscle)
    dt = 0.002
    t = np.arange(0.0, 2 * rest_s + hold_s + 0.6, dt)
    ramp = np.clip(np.minimum((t - rest_s) / 0.3, (rest_s + hold_s + 0.6 - t) / 0.3), 0.0, 1.0)
    u = np.zeros((t.size, len(MUSCLES)))
    u[:, index] = electrodes.bad_mvc[index] * ramp
    return emg_from_excitations(u, dt, electrodes, seed=seed)
