"""Can a target reach the asked ± at this (λ, ω) — with more pushes of this kind, or never?

A property's predicted std has two parts (:meth:`PropertyModel.predict`): the model's own
(calibrated) std at (λ, ω), which no push reduces, and the fit's (λ, ω) std propagated
through the model's slope. Repeating a push of the same kind divides the fit's
*random* error by ``sqrt(n)`` (:func:`~liquidtouch.models.combine.combine_ring_downs`),
but not what every such push shares: the fit's systematic error, :data:`FIT_FLOOR`
relative to λ and ω. So, with ``n`` pushes,

    std(n)² = model² + max(fit₁²/n, floor²),   fit₁ = the propagated std of one push,

and ``std(∞) = hypot(model, floor)`` is the best any number of pushes of this kind can
give. A target asked below it **cannot be told here**: the reason is the model's own
± (``"model"``), or the target's sensitivity to (λ, ω) — e.g. a deep fill, where ω
hardly moves with the height — times the fit's attainable std (``"sensitivity"``), or
the model's training range (``"domain"``: (λ, ω) outside it, or a predicted value
beyond the targets it was trained on by more than the model's own std — where the model
extrapolates, e.g. a deep fill whose saturated ω a model of shallower fills takes for
a little more than its deepest).
Otherwise :attr:`Reach.pushes_needed` says how many pushes of this kind reach it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["FIT_FLOOR", "Reach", "reach_of"]

#: The fit's systematic error relative to (λ, ω), which repeating a push of the same
#: kind does not average away: the largest per-liquid median error of the default fit
#: against the simulator's truth at the marker level, detergent aside (whose bias, its
#: shear thinning, a model trained on such fits learns): λ +1.6 %, ω +0.046 % (olive
#: oil at a 0.5× push; benchmarks/RESULTS.md "# fit bias"), rounded up to 2 % and 0.05 %.
FIT_FLOOR: tuple[float, float] = (0.02, 0.0005)


@dataclass(frozen=True)
class Reach:
    """Whether ``target`` can reach ``asked`` (its unit) at this (λ, ω) (module docstring).

    ``std_now`` is the predicted std after ``pushes`` ring-downs, ``model_std`` the part no
    push reduces, ``limit_std`` the best any number of pushes of this kind gives;
    ``pushes_needed`` the total number of pushes that reaches ``asked`` (``None`` when
    none does); ``reason`` one of ``""`` (reachable), ``"model"``, ``"sensitivity"``,
    ``"domain"``; ``message`` says it in words.
    """

    target: str
    asked: float
    std_now: float
    model_std: float
    limit_std: float
    pushes: int
    pushes_needed: int | None
    reason: str

    @property
    def met(self) -> bool:
        """The asked ± is reached now (and the answer is one the model can give)."""
        return not self.reason and math.isfinite(self.std_now) and self.std_now < self.asked

    @property
    def cannot_tell(self) -> bool:
        """No number of pushes of this kind reaches the asked ± here."""
        return bool(self.reason)

    @property
    def message(self) -> str:
        """One line: met, how many pushes it needs, or why it cannot be told here."""
        t, a = self.target, self.asked
        if self.reason == "domain":
            return (
                f"cannot tell {t} here: (λ, ω) or the answer lies outside the model's "
                "training range, where its ± would be an extrapolation"
            )
        if self.reason == "model":
            return (
                f"cannot tell {t} to ±{a:g} here: the model's own ± is {self.model_std:.3g}, "
                "which no push reduces"
            )
        if self.reason == "sensitivity":
            return (
                f"cannot tell {t} to ±{a:g} here: {t} hardly moves (λ, ω) at this point, and "
                f"the fit's attainable std gives ±{self.limit_std:.3g} at best, whatever "
                "the number of pushes of this kind"
            )
        if self.met:
            return f"{t}: ±{self.std_now:.3g} < {a:g} after {self.pushes} push(es)"
        return f"{t}: ±{self.std_now:.3g}, about {self.pushes_needed} push(es) reach ±{a:g}"

    def to_dict(self) -> dict[str, object]:
        """JSON-ready."""
        return {
            "target": self.target,
            "asked_std": self.asked,
            "std": _finite(self.std_now),
            "model_std": _finite(self.model_std),
            "limit_std": _finite(self.limit_std),
            "pushes": self.pushes,
            "pushes_needed": self.pushes_needed,
            "met": self.met,
            "cannot_tell": self.cannot_tell,
            "reason": self.reason,
            "message": self.message,
        }


def _finite(value: float) -> float | None:
    return float(value) if math.isfinite(value) else None


def reach_of(
    target: str,
    asked: float,
    *,
    model_std: float,
    fit_std: float,
    floor_std: float,
    pushes: int,
    in_domain: bool = True,
) -> Reach:
    """The :class:`Reach` of one target from its parts (module docstring: the formula).

    ``model_std``: the model's own std; ``fit_std``: the fit's std propagated through the
    model after ``pushes`` combined ring-downs; ``floor_std``: :data:`FIT_FLOOR`
    propagated the same way; all in the target's unit. A non-finite ``fit_std`` (no fit
    yet) leaves ``pushes_needed`` unknown (``None``) unless the limit already rules it out.
    """
    pushes = max(int(pushes), 1)
    limit = math.hypot(model_std, floor_std)
    one = fit_std * math.sqrt(pushes)  # the propagated std of a single push
    now = math.hypot(model_std, fit_std)
    reason = ""
    if not in_domain:
        reason = "domain"
    elif not math.isfinite(limit) or limit >= asked:
        reason = "model" if not math.isfinite(model_std) or model_std >= asked else "sensitivity"
    needed: int | None = None
    if not reason and math.isfinite(one):
        room = asked * asked - model_std * model_std
        needed = pushes if now < asked else max(pushes + 1, math.floor(one * one / room) + 1)
    return Reach(target, float(asked), now, model_std, limit, pushes, needed, reason)
