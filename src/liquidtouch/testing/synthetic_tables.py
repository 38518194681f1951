"""Synthetic feature tables shaped like the paper's sugar-water experiment (tests, benchmarks).

Physics: first sloshing mode (linear potential theory) of a rectangular container
of inner length L along the slosh and width b, fill height h:

- ω0² = g k tanh(k h), k = π / L; observed ω = sqrt(ω0² − λ²);
- λ = wall · sqrt(ν ω0 / 2) · [1/b + 1/L + k (1 − 2h/L) / sinh(2kh)] + 2 ν k²
  (Stokes boundary layer, wall/contact-line factor ``wall``).

Chosen container ("container A"): L = 120 mm, b = 60 mm, wall factor 1.5; 16-40 mm
fill is then 13-33 % of a 120 mm-tall box, ω ≈ 10-14 rad/s, λ ≈ 0.15-1.3 1/s for
water to 160 g sugar / 100 g water. Measurement noise: 4 % (log-normal) on λ,
0.3 % on ω — the oscillation fit pins the frequency far better than the decay.
Sugar-water viscosity comes from :func:`liquidtouch._core.liquids.get_liquid`
(the CRC sucrose table).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from liquidtouch._core.liquids import get_liquid

GRAVITY = 9.81
CONTAINER_A = {"length_m": 0.12, "width_m": 0.06, "wall": 1.5}
# a similar but smaller container for transfer experiments
CONTAINER_B = {"length_m": 0.10, "width_m": 0.05, "wall": 1.65}
LAMBDA_NOISE = 0.04
OMEGA_NOISE = 0.003
PAPER_HEIGHTS_MM = np.linspace(16.0, 40.0, 17)  # 1.5 mm steps; even → train (9), odd → test (8)
PAPER_CONCENTRATIONS = np.linspace(0.0, 160.0, 12)


def sugar_viscosity_cst(c: float) -> float:
    """Kinematic viscosity [cSt] of sugar water, c g sugar per 100 g water, 20 °C."""
    return get_liquid("sugar-water", sugar_concentration=float(c)).viscosity_cst


def sloshing_features(
    height_mm: np.ndarray, viscosity_cst: np.ndarray, length_m: float, width_m: float, wall: float
) -> tuple[np.ndarray, np.ndarray]:
    """Noise-free (λ [1/s], ω [rad/s]) of the first sloshing mode."""
    h = np.asarray(height_mm, dtype=float) / 1000.0
    nu = np.asarray(viscosity_cst, dtype=float) * 1e-6
    k = np.pi / length_m
    omega0 = np.sqrt(GRAVITY * k * np.tanh(k * h))
    bracket = 1 / width_m + 1 / length_m + k * (1 - 2 * h / length_m) / np.sinh(2 * k * h)
    decay = wall * np.sqrt(nu * omega0 / 2) * bracket + 2 * nu * k**2
    return decay, np.sqrt(omega0**2 - decay**2)


def sugar_table(
    heights_mm: np.ndarray,
    concentrations: np.ndarray,
    seed: int = 0,
    container: dict | None = None,
    lambda_noise: float = LAMBDA_NOISE,
    omega_noise: float = OMEGA_NOISE,
    name: str = "A",
) -> pd.DataFrame:
    """One noisy trial per (height, concentration) pair, with all label columns."""
    rng = np.random.default_rng(seed)
    h, c = (a.ravel() for a in np.meshgrid(heights_mm, concentrations, indexing="ij"))
    nu = np.array([sugar_viscosity_cst(ci) for ci in c])
    decay, omega = sloshing_features(h, nu, **(container or CONTAINER_A))
    decay = decay * np.exp(lambda_noise * rng.standard_normal(h.size))
    omega = omega * (1 + omega_noise * rng.standard_normal(h.size))
    return pd.DataFrame(
        {
            "decay_rate": decay,
            "angular_frequency": omega,
            "height_mm": h,
            "sugar_concentration": c,
            "log10_viscosity_cst": np.log10(nu),
            "container": name,
        }
    )


def paper_split(seed: int = 0) -> tuple[pd.DataFrame, pd.DataFrame]:
    """The paper's sugar experiment: train 9 heights × 12 concentrations, test the other 8 × 12."""
    train = sugar_table(PAPER_HEIGHTS_MM[0::2], PAPER_CONCENTRATIONS, seed=seed)
    test = sugar_table(PAPER_HEIGHTS_MM[1::2], PAPER_CONCENTRATIONS, seed=seed + 1000)
    return train, test


LIQUID_VISCOSITY_CST = {
    "water": 1.0,
    "mirin": 22.0,
    "corn-oil": 52.0,
    "olive-oil": 64.0,
    "detergent": 440.0,
}


def liquid_table(
    liquids: list[str], heights_mm: np.ndarray, repeats: int, seed: int = 0
) -> pd.DataFrame:
    """Trials of catalogued liquids at the given heights (``repeats`` noisy trials each)."""
    rng = np.random.default_rng(seed)
    rows = []
    for liquid in liquids:
        h = np.repeat(np.asarray(heights_mm, dtype=float), repeats)
        decay, omega = sloshing_features(
            h, np.full(h.size, LIQUID_VISCOSITY_CST[liquid]), **CONTAINER_A
        )
        decay = decay * np.exp(LAMBDA_NOISE * rng.standard_normal(h.size))
        omega = omega * (1 + OMEGA_NOISE * rng.standard_normal(h.size))
        rows.append(
            pd.DataFrame(
                {"decay_rate": decay, "angular_frequency": omega, "height_mm": h, "liquid": liquid}
            )
        )
    return pd.concat(rows, ignore_index=True)
