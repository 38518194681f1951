"""Sloshing dynamics: a mechanical-analogue model of liquid, container and compliant grasp.

Model (all SI inside, mm only at the edges)
-------------------------------------------
The liquid is replaced by its standard mechanical analogue (Abramson, NASA
SP-106; Ibrahim, *Liquid Sloshing Dynamics*): a rigid mass ``m0`` moving with
the container plus one slosh mass ``m_n`` per antisymmetric mode
``k_n = (2j−1)π/L`` (we keep the first and the weak third mode), on a spring
tuned to the linear potential-theory frequency ``ω_n² = g k_n tanh(k_n h)``
(``h`` = equivalent depth A/W for a cylinder on its side), with
``m_n = M·8 tanh(k_n h)/((2j−1)³π³ h/L)``.

An upright round bottle of radius ``R`` (shape ``upright``) has the same analogue
with the antisymmetric Bessel modes: ``k_n = ξ_n/R``, ``ξ`` the roots of J1'
(1.841, 5.331), and ``m_n = M·2 tanh(ξ_n h/R)/(ξ_n(ξ_n² − 1) h/R)`` (Abramson,
SP-106, ch. 6); its wave steepness per slosh-mass displacement is taken as the
rectangular channel's of length ``2R``, and its linear damping is the empirical
upright-cylinder rate of Mikishev & Dorozhkin (Abramson SP-106, eq. 4.21)
``λ = ω·0.79 sqrt(ν)/(g^¼ R^¾)·[1 + 0.318/sinh(ξh/R)·(1 + (1 − h/R)/cosh(ξh/R))]``
(times the container's wall factor, 1 for the catalogue's bottle), in place of the
rectangular Stokes bracket.

A push along the grasp axis (world ``y``) sloshes the liquid across the container
(:meth:`~liquidtouch._core.containers.Container.along`); the simulator keeps the
slosh force on the gels' lateral (shear) axis either way — a simplification: a real
push along the grasp axis loads the gels mostly in their normal direction.

Damping of mode ``n`` (amplitude decay rate) is the Stokes boundary-layer rate
``α = sqrt(νω/2)·[1/b + 1/L + k(1 − 2h/L)/sinh(2kh)]`` times the container's
wall factor, plus bulk dissipation ``2νk²`` and a small contact-line term. It
grows with the wave steepness ``s = k·a`` (``a`` the wall elevation, which is
``4 tanh(kh)/((2j−1)π)`` times the slosh-mass displacement):
``λ(s) = λ_lin·(1 + κ1·s²) + κ2·ω·s²`` — the faster early decay the paper sees
(κ1 = 8, κ2 = 0.15 are choices: the decay rate of water roughly doubles at
the steepness right after a firm push, s ≈ 0.2, and is within ~5 % of the
small-amplitude value once s < 0.05). For a shear-thinning liquid ``ν`` follows the boundary-layer
shear rate ``γ̇ ≈ ω·x/δ``, ``δ = sqrt(2ν/ω)``.

The container (with ``m0``) is held by the gels and the arm, lumped into one
lateral spring–damper to the hand's commanded position ``X_h(t)`` (stiffness
``K_s``, damping ratio ~0.15, 15–20 Hz with a plastic container). So a heavy
container moves a little against the grasp and the force on the fingers is
``−(M_r Ẍ + Σ m_n(Ẍ + ẍ_n))``, not the slosh force alone.

Integration: the six states ``(z = X − X_h, ż, x_n, ẋ_n)`` are integrated by
``scipy.integrate.solve_ivp`` (explicit RK45, rtol 1e-5, max step 20 ms; the
error control resolves the 16 Hz support mode; relative error < 1e-5 against
an rtol 1e-9 DOP853 reference) and sampled on the output grid; the
model is non-linear through the amplitude-dependent damping, so the exact
linear (matrix exponential) solution does not apply. The right-hand side is
written with plain float arithmetic, which keeps one 13 s trial at ~0.1 s.
Arm vibration is small and linear, so it is added afterwards as the exact
steady-state response of the linearised system (:func:`sinusoid_response`)
instead of forcing the solver to resolve 10-30 Hz inputs.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from liquidtouch._core.containers import Container
from liquidtouch._core.liquids import LiquidProperties

GRAVITY_M_S2 = 9.81
NONLINEAR_GAIN = 8.0  # κ1: relative growth of the damping per squared wave steepness
BREAKING_GAIN = 0.15  # κ2: extra damping ∝ ω·steepness², a choice
SUPPORT_DAMPING_RATIO = 0.15
#: roots of J1' (the upright cylinder's antisymmetric modes): the first two
BESSEL_ROOTS = (1.8412, 5.3314)
#: Mikishev & Dorozhkin's coefficient of the upright cylinder's damping ratio (Abramson SP-106)
UPRIGHT_DAMPING_COEFFICIENT = 0.79


@dataclass(frozen=True)
class SloshMode:
    """One antisymmetric slosh mode of the mechanical analogue (SI units)."""

    order: int  # 1, 3, ... (number of half-wavelengths along the length)
    wavenumber_1_m: float
    natural_frequency: float  # undamped ω_n [rad/s]
    mass_kg: float
    height_m: float  # height of the slosh mass above the lowest inner point
    wall_term_1_m: float  # wall factor × Stokes bracket [1/m]
    bulk_term_1_m2: float  # 2k², multiplies ν
    steepness_per_m: float  # wave steepness per metre of slosh-mass displacement

    def linear_decay_rate(self, viscosity_m2_s: float, contact_line: float) -> float:
        """Small-amplitude amplitude decay rate λ [1/s] of the uncoupled mode.

        ``wall term · sqrt(νω/2) + 2k²·ν + contact_line``: the Stokes boundary
        layer (wall factor × bracket, see :func:`slosh_system`), bulk dissipation
        and the contact-line term [1/s]; ``viscosity_m2_s`` is ν [m²/s]. The one
        implementation of the linear rate (floats or arrays).
        """
        w = self.natural_frequency
        return (
            self.wall_term_1_m * (viscosity_m2_s * w / 2.0) ** 0.5
            + self.bulk_term_1_m2 * viscosity_m2_s
            + contact_line
        )


@dataclass(frozen=True)
class SloshSystem:
    """Everything the dynamics need: modes, masses, grasp support, liquid."""

    modes: tuple[SloshMode, ...]
    liquid: LiquidProperties
    liquid_mass_kg: float
    container_mass_kg: float
    rigid_mass_kg: float  # container + non-sloshing liquid
    rigid_height_m: float  # height of the non-sloshing liquid's centre
    support_stiffness_n_m: float
    support_damping_n_s_m: float
    contact_line_damping: float

    @property
    def total_mass_kg(self) -> float:
        """Container plus liquid [kg]."""
        return self.container_mass_kg + self.liquid_mass_kg

    def linear_decay_rates(self) -> np.ndarray:
        """Small-amplitude decay rate of each uncoupled mode [1/s] (zero-shear viscosity)."""
        nu = self.liquid.viscosity_m2_s
        return np.array([m.linear_decay_rate(nu, self.contact_line_damping) for m in self.modes])

    def state_matrix(self) -> np.ndarray:
        """The linearised (small-amplitude) state matrix of ``(z, ż, x_1, ẋ_1, ...)``."""
        n = 2 + 2 * len(self.modes)
        a = np.zeros((n, n))
        k_s, c_s, m_r = self.support_stiffness_n_m, self.support_damping_n_s_m, self.rigid_mass_kg
        # container acceleration as a row over the state
        acc = np.zeros(n)
        acc[0], acc[1] = -k_s / m_r, -c_s / m_r
        lam = self.linear_decay_rates()
        for i, mode in enumerate(self.modes):
            acc[2 + 2 * i] += mode.mass_kg * mode.natural_frequency**2 / m_r
            acc[3 + 2 * i] += 2.0 * mode.mass_kg * lam[i] / m_r
        a[0, 1] = 1.0
        a[1] = acc
        for i, mode in enumerate(self.modes):
            a[2 + 2 * i, 3 + 2 * i] = 1.0
            row = -acc.copy()
            row[2 + 2 * i] -= mode.natural_frequency**2
            row[3 + 2 * i] -= 2.0 * lam[i]
            a[3 + 2 * i] = row
        return a

    def slow_mode(self) -> tuple[float, float]:
        """True small-amplitude ``(λ, ω)`` of the slow (first) slosh mode of the coupled system.

        The eigenvalue of :meth:`state_matrix` nearest the uncoupled first mode;
        ``ω`` is the damped angular frequency (the paper's ``sqrt(ω0² − λ²)``).
        """
        eig = np.linalg.eigvals(self.state_matrix())
        mode = self.modes[0]
        lam0 = self.linear_decay_rates()[0]
        target = complex(-lam0, math.sqrt(max(mode.natural_frequency**2 - lam0**2, 0.0)))
        best = eig[np.argmin(np.abs(eig - target))]
        return float(-best.real), float(abs(best.imag))


def slosh_system(
    liquid: LiquidProperties,
    container: Container,
    height_mm: float,
    *,
    wall_factor: float | None = None,
    contact_line_damping: float | None = None,
    support_stiffness_n_m: float = 2500.0,
    n_modes: int = 2,
    axis: str = "x",
) -> SloshSystem:
    """Build the mechanical analogue of ``liquid`` filled to ``height_mm`` in ``container``,
    pushed along world ``axis`` (``"x"``: the container's length; ``"y"``: across it)."""
    container = container.along(axis)
    container.check_height(height_mm)
    if container.upright:
        return _upright_system(
            liquid, container, height_mm, wall_factor, contact_line_damping,
            support_stiffness_n_m, n_modes,
        )  # fmt: skip
    area_mm2, surface_width_mm = container.cross_section(height_mm)
    length = container.length_mm * 1e-3
    b = surface_width_mm * 1e-3
    h = area_mm2 / surface_width_mm * 1e-3  # equivalent depth A/W
    bottom_offset = height_mm * 1e-3 - h  # equivalent channel's bottom above the lowest point
    liquid_mass = liquid.density_kg_m3 * area_mm2 * 1e-6 * length
    factor = container.wall_factor if wall_factor is None else wall_factor
    modes = []
    for j in range(1, n_modes + 1):
        order = 2 * j - 1
        k = order * math.pi / length
        th = math.tanh(k * h)
        # Stokes boundary-layer bracket [1/m]: side walls, end walls, bottom
        bracket = 1.0 / b + 1.0 / length + k * (1.0 - 2.0 * h / length) / math.sinh(2.0 * k * h)
        modes.append(
            SloshMode(
                order=order,
                wavenumber_1_m=k,
                natural_frequency=math.sqrt(GRAVITY_M_S2 * k * th),
                mass_kg=liquid_mass * 8.0 * th / (order**3 * math.pi**3 * h / length),
                height_m=bottom_offset + h / 2.0 - math.tanh(k * h / 2.0) / k,
                wall_term_1_m=factor * max(bracket, 1.0 / b),
                bulk_term_1_m2=2.0 * k * k,
                steepness_per_m=4.0 * th / length,
            )
        )
    return _system(
        modes, liquid, liquid_mass, container, height_mm, contact_line_damping,
        support_stiffness_n_m,
    )  # fmt: skip


def _upright_system(
    liquid: LiquidProperties,
    container: Container,
    height_mm: float,
    wall_factor: float | None,
    contact_line_damping: float | None,
    support_stiffness_n_m: float,
    n_modes: int,
) -> SloshSystem:
    """The mechanical analogue of an upright round bottle (module docstring)."""
    radius = container.length_mm / 2.0 * 1e-3
    h = height_mm * 1e-3
    liquid_mass = liquid.density_kg_m3 * container.liquid_volume_mm3(height_mm) * 1e-9
    factor = container.wall_factor if wall_factor is None else wall_factor
    modes = []
    for j, xi in enumerate(BESSEL_ROOTS[:n_modes]):
        k = xi / radius
        th = math.tanh(k * h)
        w = math.sqrt(GRAVITY_M_S2 * k * th)
        shape = 1.0 + 0.318 / math.sinh(k * h) * (1.0 + (1.0 - h / radius) / math.cosh(k * h))
        # λ = ζ ω with ζ ∝ sqrt(ν) (Mikishev & Dorozhkin), written as wall term × sqrt(νω/2)
        zeta_per_sqrt_nu = UPRIGHT_DAMPING_COEFFICIENT / (GRAVITY_M_S2**0.25 * radius**0.75)
        modes.append(
            SloshMode(
                order=2 * j + 1,
                wavenumber_1_m=k,
                natural_frequency=w,
                mass_kg=liquid_mass * 2.0 * th / (xi * (xi * xi - 1.0) * h / radius),
                height_m=h / 2.0 - math.tanh(k * h / 2.0) / k,
                wall_term_1_m=factor * zeta_per_sqrt_nu * shape * math.sqrt(2.0 * w),
                bulk_term_1_m2=2.0 * k * k,
                steepness_per_m=4.0 * th / (2.0 * radius),
            )
        )
    return _system(
        modes, liquid, liquid_mass, container, height_mm, contact_line_damping,
        support_stiffness_n_m,
    )  # fmt: skip


def _system(
    modes: list[SloshMode],
    liquid: LiquidProperties,
    liquid_mass: float,
    container: Container,
    height_mm: float,
    contact_line_damping: float | None,
    support_stiffness_n_m: float,
) -> SloshSystem:
    """The :class:`SloshSystem` of ``modes``: the rigid rest and the grasp's support."""
    sloshing = sum(m.mass_kg for m in modes)
    container_mass = container.mass_g * 1e-3
    rigid = container_mass + liquid_mass - sloshing
    return SloshSystem(
        modes=tuple(modes),
        liquid=liquid,
        liquid_mass_kg=liquid_mass,
        container_mass_kg=container_mass,
        rigid_mass_kg=rigid,
        rigid_height_m=height_mm * 1e-3 / 2.0,
        support_stiffness_n_m=support_stiffness_n_m,
        support_damping_n_s_m=2.0
        * SUPPORT_DAMPING_RATIO
        * math.sqrt(support_stiffness_n_m * rigid),
        contact_line_damping=(
            container.contact_line_damping if contact_line_damping is None else contact_line_damping
        ),
    )


def decay_rate_function(system: SloshSystem, mode: SloshMode) -> Callable:
    """The amplitude-dependent decay rate ``λ(s)`` [1/s] of ``mode`` as a function ``(x, v)``.

    ``x`` [m] and ``v`` [m/s] are the slosh mass's displacement and velocity
    (floats, or arrays over time); ``λ(s) = λ_lin·(1 + κ1·s²) + κ2·ω·s²`` with
    ``s`` the wave steepness (module docstring). A shear-thinning liquid's
    viscosity follows the boundary-layer shear rate ``γ̇ = ω·a/δ``,
    ``δ = sqrt(2ν0/ω)``. A closure over plain floats: it is the hot path of a trial.
    """
    liquid, cl = system.liquid, system.contact_line_damping
    w = mode.natural_frequency
    inv_w = 1.0 / w
    steep2 = mode.steepness_per_m * mode.steepness_per_m
    thinning = liquid.shear_thinning
    linear = mode.linear_decay_rate(liquid.viscosity_m2_s, cl)
    delta = (2.0 * liquid.viscosity_m2_s * inv_w) ** 0.5  # boundary-layer thickness [m]
    k1, k2w = NONLINEAR_GAIN, BREAKING_GAIN * w

    def rate(x, v):
        vw = v * inv_w
        amp2 = x * x + vw * vw  # squared oscillation amplitude a² [m²]
        s2 = steep2 * amp2
        lam = linear
        if thinning:
            nu = liquid.effective_viscosity_m2_s(w * amp2**0.5 / delta)
            lam = mode.linear_decay_rate(nu, cl)
        return lam * (1.0 + k1 * s2) + k2w * s2

    return rate


def accelerations(system: SloshSystem, state):
    """Container acceleration ``Ẍ`` and slosh-mass relative accelerations ``ẍ_n``.

    ``state`` is ``(z, ż, x_1, ẋ_1, ...)`` (floats, or arrays over time).
    """
    z, zd = state[0], state[1]
    x = [state[2 + 2 * i] for i in range(len(system.modes))]
    v = [state[3 + 2 * i] for i in range(len(system.modes))]
    rates = [decay_rate_function(system, m) for m in system.modes]
    lam = [rate(xi, vi) for rate, xi, vi in zip(rates, x, v, strict=True)]
    reaction = [
        m.mass_kg * (m.natural_frequency**2 * xi + 2.0 * li * vi)
        for m, xi, vi, li in zip(system.modes, x, v, lam, strict=True)
    ]
    support = -system.support_stiffness_n_m * z - system.support_damping_n_s_m * zd
    acc = (support + sum(reaction)) / system.rigid_mass_kg
    rel = [-acc - r / m.mass_kg for r, m in zip(reaction, system.modes, strict=True)]
    return acc, rel


def integrate(
    system: SloshSystem,
    t_s: np.ndarray,
    hand_acceleration: Callable[[float], float],
    initial_state: np.ndarray,
    *,
    method: str = "RK45",
    max_step_s: float = 0.02,
    rtol: float = 1e-5,
) -> np.ndarray:
    """Integrate the dynamics; return the state sampled at ``t_s`` as ``(n_states, n)``.

    ``hand_acceleration(t)`` is the commanded lateral acceleration of the hand
    [m/s²] (push, hold, arm vibration).
    """
    from scipy.integrate import solve_ivp

    rhs = _make_rhs(system, hand_acceleration)
    sol = solve_ivp(
        rhs,
        (float(t_s[0]), float(t_s[-1])),
        np.asarray(initial_state, dtype=float),
        t_eval=t_s,
        method=method,
        rtol=rtol,
        atol=rtol * 1e-4,
        max_step=max_step_s,
    )
    if not sol.success:  # pragma: no cover - the model is smooth and bounded
        raise RuntimeError(f"slosh integration failed: {sol.message}")
    return sol.y


def _make_rhs(
    system: SloshSystem, hand_acceleration: Callable[[float], float]
) -> Callable[[float, np.ndarray], list[float]]:
    """The ODE right-hand side as a closure over plain floats (the hot path of a trial).

    Same equations as :func:`accelerations`, on floats so that one call costs a few µs.
    """
    k_s, c_s = system.support_stiffness_n_m, system.support_damping_n_s_m
    inv_mr = 1.0 / system.rigid_mass_kg
    modes = [
        (decay_rate_function(system, m), m.natural_frequency**2, m.mass_kg) for m in system.modes
    ]
    idx = range(len(modes))

    def rhs(t: float, y: np.ndarray) -> list[float]:
        state = y.tolist()
        total = -k_s * state[0] - c_s * state[1]
        reactions = []
        for i in idx:
            rate, w2, mass = modes[i]
            x, v = state[2 + 2 * i], state[3 + 2 * i]
            r = mass * (w2 * x + 2.0 * rate(x, v) * v)
            reactions.append(r / mass)
            total += r
        acc = total * inv_mr
        out = [state[1], acc - hand_acceleration(t)]
        for i in idx:
            out.append(state[3 + 2 * i])
            out.append(-acc - reactions[i])
        return out

    return rhs


def sinusoid_response(
    system: SloshSystem,
    t_s: np.ndarray,
    frequencies_hz: np.ndarray,
    accel_amplitudes_m_s2: np.ndarray,
    phases_rad: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Steady-state linear response to hand accelerations ``Σ a_i cos(2π f_i t + φ_i)``.

    Returns the state ``(n_states, n)`` and the hand acceleration ``(n,)``.
    """
    a = system.state_matrix()
    b = np.zeros(a.shape[0])
    b[1] = -1.0  # the hand acceleration enters z̈ = Ẍ − Ẍ_h
    state = np.zeros((a.shape[0], t_s.size))
    hand = np.zeros(t_s.size)
    eye = np.eye(a.shape[0])
    for f, amp, phase in zip(frequencies_hz, accel_amplitudes_m_s2, phases_rad, strict=True):
        w = 2.0 * np.pi * f
        gain = np.linalg.solve(1j * w * eye - a, b * amp * np.exp(1j * phase))
        rot = np.exp(1j * w * t_s)
        state += np.real(gain[:, None] * rot[None, :])
        hand += amp * np.cos(w * t_s + phase)
    return state, hand
