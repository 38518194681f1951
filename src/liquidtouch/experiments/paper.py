"""The paper's published numbers: the one copy the experiments, figures and report use.

Huang, Guo, Yuan, "Understanding Dynamic Tactile Sensing for Liquid Property
Estimation", RSS 2022 (arXiv:2205.08771). Each number carries its unit and
``source``: where in the paper it comes from (the experiment and the
quantity). Units: h in mm, c in g sugar per 100 g water (not wt%), μ = log10
of the kinematic viscosity in cSt (an MAE of μ is in decades), accuracy in %.
"""

from __future__ import annotations

from dataclasses import dataclass

CITATION = (
    "Huang, Guo, Yuan: Understanding Dynamic Tactile Sensing for Liquid Property Estimation, "
    "RSS 2022 (arXiv:2205.08771)"
)


@dataclass(frozen=True)
class PaperValue:
    """One published number: value, unit and where in the paper it is."""

    value: float
    unit: str
    source: str

    def label(self) -> str:
        """``"paper: <value> <unit> (<source>)"`` for legends and captions."""
        return f"paper: {self.value:g} {self.unit} ({self.source})".replace("  ", " ")


#: Units of the three regression targets (the keys of the feature tables).
UNITS = {
    "height_mm": "mm",
    "sugar_concentration": "g/100 g water",
    "log10_viscosity_cst": "log10 cSt",
}

_CLASSIFICATION = "liquid classification, test accuracy"
_FT = "GelSight vs wrist F/T, classification test accuracy"
_SUGAR = "sugar water in the grooved cuboid, test MAE"
_OTHER = "other liquids by the sugar-water GPR, MAE"
_CONTAINERS = "other containers, GPR test MAE"
_TRANSFER = "container transfer: tuning points that suffice"


def _targets(source: str, h: float, c: float, mu: float) -> dict[str, PaperValue]:
    values = {"height_mm": h, "sugar_concentration": c, "log10_viscosity_cst": mu}
    return {t: PaperValue(v, UNITS[t], source) for t, v in values.items()}


#: Experiment 1: SVM on GelSight (λ, ω), water / olive oil / detergent.
CLASSIFICATION_ACCURACY = PaperValue(100.0, "%", _CLASSIFICATION)

#: Experiment 2: the same classification from GelSight and from the wrist F/T sensor.
FORCE_TORQUE_ACCURACY = {
    "GelSight": PaperValue(100.0, "%", _FT),
    "wrist F/T": PaperValue(34.3, "%", _FT),
    "wrist F/T, best-effort fit": PaperValue(34.3, "%", _FT),
}

#: Experiment 3: test MAE per model kind and target (physics-gpr is ours, not in the paper).
SUGAR_TEST_MAE = {
    "gpr": _targets(f"{_SUGAR} (GPR)", 0.56, 15.3, 0.16),
    "quadratic": _targets(f"{_SUGAR} (quadratic model)", 0.84, 20.0, 0.23),
}

#: Experiment 4: MAE of h and μ per liquid (the paper gives no c for them).
OTHER_LIQUIDS_MAE = {
    liquid: {
        "height_mm": PaperValue(h, "mm", f"{_OTHER} ({liquid})"),
        "log10_viscosity_cst": PaperValue(mu, "log10 cSt", f"{_OTHER} ({liquid})"),
    }
    for liquid, h, mu in (
        ("olive-oil", 1.50, 0.12),
        ("corn-oil", 1.46, 0.12),
        ("mirin", 0.99, 0.35),
    )
}

#: Experiment 5: GPR test MAE per container and target.
CONTAINERS_TEST_MAE = {
    "cylinder": _targets(f"{_CONTAINERS} (cylinder)", 0.84, 13.5, 0.15),
    "cuboid": _targets(f"{_CONTAINERS} (cuboid)", 1.96, 20.4, 0.23),
    "glass": _targets(f"{_CONTAINERS} (glass)", 0.91, 12.9, 0.14),
}

#: Experiment 7: the number of cuboid trials the paper found enough for the transfer.
TRANSFER_POINTS = PaperValue(15.0, "trials", _TRANSFER)


def full_data_c_mae(container: str) -> PaperValue | None:
    """The paper's GPR test MAE of c with all training data in ``container`` (or None)."""
    if container == "grooved-cuboid":
        return SUGAR_TEST_MAE["gpr"]["sugar_concentration"]
    return CONTAINERS_TEST_MAE.get(container, {}).get("sugar_concentration")
