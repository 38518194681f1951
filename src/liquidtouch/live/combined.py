"""The stream's answer from all its ring-downs: combined, predicted, and whether it can tell.

A stream with several pushes of one bottle (``run-trial --max-pushes``, or a recording
of several pushes) has several final ring-downs (:mod:`liquidtouch.live.ring_downs`).
Each stays as it was; :func:`combined_answer` combines their (λ, ω) by their ±
(:func:`~liquidtouch.models.combine.combine_ring_downs`: the one implementation, also the
API's), predicts the properties from the combination with a regression model, and —
given ``until_std`` — says per target whether it is met, how many pushes would reach it,
or that no push of this kind can (:meth:`~liquidtouch.models.property_model.PropertyModel.reach`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from liquidtouch.errors import LiquidTouchError
from liquidtouch.live.properties import predict_with_fit_std
from liquidtouch.live.updates import LiveUpdate
from liquidtouch.models.combine import RingDownEstimate, combine_ring_downs

__all__ = ["combined_answer", "next_push"]


def combined_answer(
    finals: Sequence[LiveUpdate],
    model: object | None = None,
    until_std: Mapping[str, float] | None = None,
) -> dict[str, object]:
    """JSON-ready: the combination of the final ring-downs' updates ``finals`` (``{}`` when
    none has a usable estimate), with ``predicted`` (``{target: [mean, std]}``) and
    ``reach`` (``{target: Reach.to_dict()}``) when ``model`` is a regression model."""
    estimates = [
        RingDownEstimate(
            u.decay_rate, u.decay_rate_std, u.angular_frequency, u.angular_frequency_std
        )
        for u in finals
    ]
    try:
        combined = combine_ring_downs(estimates)
    except LiquidTouchError:
        return {}
    out = combined.to_dict()
    if getattr(model, "kind", None) != "regression":
        return out
    features = (
        combined.decay_rate, combined.decay_rate_std,
        combined.angular_frequency, combined.angular_frequency_std,
    )  # fmt: skip
    out["predicted"] = {t: list(v) for t, v in predict_with_fit_std(model, *features).items()}
    if until_std:
        X, X_std = combined.features()
        reach = model.reach(X, X_std, until_std, pushes=combined.n)
        out["reach"] = {t: r.to_dict() for t, r in reach.items()}
    return out


def next_push(combined: Mapping[str, object]) -> tuple[bool, str]:
    """``(push again?, why)`` from a :func:`combined_answer` with ``reach``.

    Stop when every target is met, or when one cannot be told here (no number of pushes
    of this kind would reach it: another push only costs time); otherwise push again.
    Without a combination (no final ring-down yet) or without ``reach``: push again.
    """
    reach = combined.get("reach") if combined else None
    if not reach:
        return True, "no ring-down estimate to judge yet"
    cannot = [r["message"] for r in reach.values() if r["cannot_tell"]]
    if cannot:
        return False, "; ".join(cannot)
    if all(r["met"] for r in reach.values()):
        return False, "every target met: " + "; ".join(r["message"] for r in reach.values())
    return True, "; ".join(r["message"] for r in reach.values() if not r["met"])
