"""The simulator is a lower layer: importing it must not load the estimation pipeline.

Each check runs in a fresh interpreter, so modules other tests imported do not hide
(or fake) a leak.
"""

from __future__ import annotations

import json
import subprocess
import sys

FORBIDDEN = (
    "liquidtouch.tracking",
    "liquidtouch.signal.tactile",
    "liquidtouch.ring_down.start",
    "liquidtouch.fit",
    "liquidtouch.models",
    "liquidtouch.extraction.pipeline",
    "liquidtouch.extraction.wrench",
    "liquidtouch.batch.features",
)

_SCRIPT = """
import importlib, json, pkgutil, sys
import liquidtouch.sim
names = [m.name for m in pkgutil.iter_modules(liquidtouch.sim.__path__, "liquidtouch.sim.")]
for name in names:
    importlib.import_module(name)
{extra}
print(json.dumps({{"imported": names, "loaded": sorted(sys.modules)}}))
"""


def _import_sim_fresh(extra: str = "") -> tuple[list[str], list[str]]:
    """Import every ``liquidtouch.sim`` module in a new interpreter: (imported, leaked)."""
    done = subprocess.run(
        [sys.executable, "-c", _SCRIPT.format(extra=extra)],
        capture_output=True,
        text=True,
        timeout=120,
        check=True,
    )
    result = json.loads(done.stdout.strip().splitlines()[-1])
    leaked = [
        name
        for name in result["loaded"]
        if any(name == bad or name.startswith(bad + ".") for bad in FORBIDDEN)
    ]
    return result["imported"], leaked


def test_importing_every_sim_module_loads_no_estimation_module():
    imported, leaked = _import_sim_fresh()
    # the walk really covered the package (not an empty or wrong path)
    assert {"liquidtouch.sim.trial", "liquidtouch.sim.slosh", "liquidtouch.sim.gelsight"} <= set(
        imported
    )
    assert leaked == [], f"liquidtouch.sim imports estimation modules: {leaked}"


def test_the_layer_check_sees_a_leak():
    # the same check must fail if a sim module pulled in, e.g., the signal chain
    _, leaked = _import_sim_fresh("import liquidtouch.signal.tactile, liquidtouch.batch.features")
    assert "liquidtouch.signal.tactile" in leaked
    assert "liquidtouch.batch.features" in leaked
