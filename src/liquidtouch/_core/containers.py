"""Container catalogue: inner geometry, wall factor and mass of each container.

Every container is held lying on its side by the two fingers, which press on
its two large side faces; the liquid sloshes along the container's length
``length_mm`` (world ``x``), the fill height is measured vertically from the
lowest inner point, and ``width_mm`` is the inner size along the grasp axis.

Where the numbers come from (all are choices consistent with the paper, which
gives no drawings): the paper fills the grooved cuboid 16-40 mm, "25-75 %
full", so its inner height is ~55-64 mm (we take 60 mm); its length is chosen
so that the first slosh mode stays below the signal's 3 Hz low-pass (1.9-2.6
Hz over 16-40 mm). The plain cuboid (15-38 mm fills), the cylinder on its side
(12-35 mm) and the glass container (22-39 mm) are sized the same way from the
paper's fill ranges. Wall factors multiply the Stokes boundary-layer damping
(1.4-1.65, the empirical range for real containers; grooves dissipate more,
smooth glass less).
``contact_line_damping`` is the small viscosity-independent contact-line term
[1/s]. Masses: thin plastic 40-70 g; the glass container is heavy (320 g),
comparable to the liquid it holds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from liquidtouch.errors import CatalogueError


@dataclass(frozen=True)
class Container:
    """Inner geometry [mm], shape, wall factor, contact-line damping [1/s] and mass [g]."""

    name: str
    shape: str  # "box" or "cylinder" (a cylinder lying on its side, axis along x)
    length_mm: float
    width_mm: float
    depth_mm: float
    mass_g: float
    wall_factor: float
    contact_line_damping: float
    note: str = ""

    def check_height(self, height_mm: float) -> None:
        """Raise :class:`CatalogueError` unless ``0 < height_mm < depth_mm``."""
        if not (math.isfinite(height_mm) and 0.0 < height_mm < self.depth_mm):
            raise CatalogueError(
                f"fill height {height_mm} mm does not fit container {self.name!r} "
                f"(inner height {self.depth_mm:g} mm)"
            )

    def cross_section(self, height_mm: float) -> tuple[float, float]:
        """Wetted cross-section area [mm²] and free-surface width [mm] at fill ``height_mm``.

        The cross-section is perpendicular to the slosh direction.
        """
        self.check_height(height_mm)
        if self.shape == "box":
            return self.width_mm * height_mm, self.width_mm
        r = self.depth_mm / 2.0
        d = r - height_mm
        half_angle = math.acos(d / r)
        area = r * r * (half_angle - math.sin(half_angle) * math.cos(half_angle))
        return area, 2.0 * math.sqrt(max(r * r - d * d, 0.0))

    def equivalent_depth_mm(self, height_mm: float) -> float:
        """Depth of the equivalent rectangular channel, A/W (equals the height for a box)."""
        area, surface_width = self.cross_section(height_mm)
        return area / surface_width

    def fill_fraction(self, height_mm: float) -> float:
        """Fraction of the inner volume that is filled (0-1)."""
        full, _ = self.cross_section(self.depth_mm * (1 - 1e-12))
        return self.cross_section(height_mm)[0] / full


CONTAINERS: dict[str, Container] = {
    "grooved-cuboid": Container(
        "grooved-cuboid", "box", 100.0, 55.0, 60.0, 60.0, 1.60, 0.02,
        note="the paper's main container; grooved walls",
    ),
    "cuboid": Container(
        "cuboid", "box", 112.0, 62.0, 54.0, 55.0, 1.45, 0.02, note="smooth plastic cuboid"
    ),
    "cylinder": Container(
        "cylinder", "cylinder", 125.0, 50.0, 50.0, 45.0, 1.50, 0.02,
        note="plastic bottle on its side (inner diameter 50 mm)",
    ),
    "glass": Container(
        "glass", "box", 95.0, 60.0, 56.0, 320.0, 1.40, 0.015,
        note="heavy glass container, mass comparable to the liquid's",
    ),
}  # fmt: skip


def get_container(name: str) -> Container:
    """The container called ``name``; :class:`CatalogueError` listing known names if unknown."""
    container = CONTAINERS.get(name)
    if container is None:
        raise CatalogueError(
            f"unknown container {name!r}; known containers: {', '.join(CONTAINERS)}"
        )
    return container
