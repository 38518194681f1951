"""λ bias of the tactile signal's low-pass: a damped cosine through ``tactile_signal`` + the fit.

A broad spectral line (detergent: ω ≈ 14.5 rad/s, λ 3-6 1/s) reaches into the
low-pass's roll-off; the filter then narrows the line and the fitted λ comes out
low. Each row: synthetic marker tracks (a few markers moving along one direction,
``x = A e^{-λt} cos(ωt + φ)`` after a 1 s rest, 8 s in all), through
:func:`~liquidtouch.signal.tactile_signal` at a given cut-off and the default fit
(free decay, ``auto`` model; noise-free also the single-mode fit) against the truth;
noise-free and with white marker noise (σ px, several seeds: the default fit's median
bias and the λ scatter's std, the noise cost of a higher cut-off).

Usage: ``python benchmarks/lowpass_bias.py [--fps 25] [--cutoffs 3 4 5 6] [--seeds 8]``
"""

from __future__ import annotations

import argparse

import numpy as np

from liquidtouch.extraction.fit_settings import FitSettings
from liquidtouch.signal.tactile import tactile_signal
from liquidtouch.tracking.tracks import MarkerTracks

REST_S = 1.0
DURATION_S = 8.0
AMPLITUDE_PX = 1.5


def ring_down_tracks(
    lam: float,
    omega: float,
    fps: float,
    noise_px: float,
    seed: int,
    hold_px: float = AMPLITUDE_PX,
    n_markers: int = 6,
) -> MarkerTracks:
    """Synthetic tracks: ``n_markers`` markers ringing down together (weights 1..0.5)."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, DURATION_S, 1.0 / fps)
    tau = np.clip(t - REST_S, 0.0, None)
    x = np.where(t >= REST_S, AMPLITUDE_PX * np.exp(-lam * tau) * np.cos(omega * tau), 0.0)
    x[t < REST_S] = hold_px  # held, then released (a step when hold_px != AMPLITUDE_PX)
    weights = np.linspace(1.0, 0.5, n_markers)
    reference = np.column_stack([np.linspace(100, 200, n_markers), np.full(n_markers, 120.0)])
    motion = np.zeros((t.size, n_markers, 2))
    motion[:, :, 0] = np.outer(x, weights)
    motion[:, :, 1] = 0.3 * np.outer(x, weights)
    motion += noise_px * rng.standard_normal(motion.shape)
    return MarkerTracks(
        t=t,
        positions=reference + motion,
        valid=np.ones((t.size, n_markers), bool),
        reference=reference,
    )


def fitted_lambda(tracks: MarkerTracks, cutoff_hz: float | None, model: str = "auto") -> float:
    """λ [1/s] of the default fit (free decay, ``model``) of the tracks' signal; NaN if refused."""
    signal = tactile_signal([tracks], lowpass_hz=cutoff_hz)
    try:
        return float(FitSettings(model=model).fit(signal.t, signal.u).decay_rate)
    except Exception:  # a refused fit counts as missing
        return float("nan")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fps", type=float, default=25.0)
    parser.add_argument("--omega", type=float, default=14.5, help="rad/s")
    parser.add_argument("--lambdas", type=float, nargs="+", default=[1.0, 2.0, 3.0, 4.5, 6.0])
    parser.add_argument("--cutoffs", type=float, nargs="+", default=[3.0, 4.0, 5.0, 6.0])
    parser.add_argument("--noise", type=float, default=0.05, help="marker noise [px]")
    parser.add_argument("--seeds", type=int, default=8)
    args = parser.parse_args()
    print(f"fps {args.fps:g}, ω {args.omega:g} rad/s, σ {args.noise:g} px, {args.seeds} seeds")
    print(
        "| λ [1/s] | cut-off [Hz] | noise-free: default fit | noise-free: single-mode "
        "| noisy: median bias | noisy: λ std |"
    )
    print("|---|---|---|---|---|---|")
    for lam in args.lambdas:
        for cutoff in args.cutoffs:
            clean_tracks = ring_down_tracks(lam, args.omega, args.fps, 0.0, 0)
            clean = fitted_lambda(clean_tracks, cutoff)
            single = fitted_lambda(clean_tracks, cutoff, "single-mode")
            noisy = np.array(
                [
                    fitted_lambda(
                        ring_down_tracks(lam, args.omega, args.fps, args.noise, s), cutoff
                    )
                    for s in range(args.seeds)
                ]
            )
            print(
                f"| {lam:g} | {cutoff:g} | {100 * (clean / lam - 1):+.1f} % | "
                f"{100 * (single / lam - 1):+.1f} % | "
                f"{100 * (np.nanmedian(noisy) / lam - 1):+.1f} % | "
                f"{100 * np.nanstd(noisy) / lam:.1f} % |",
                flush=True,
            )


if __name__ == "__main__":
    main()
