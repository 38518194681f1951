"""Watch a replayed trial in the live view in headless Chromium and check what the page shows.

    .venv/bin/python benchmarks/live/live_browser.py OUT [--png docs/live_view.png --palette 256]

Simulates a short trial (water, 25 mm, GelSight Mini videos) and a small property model,
serves the live view on 127.0.0.1, replays the trial in real time and checks the page in
headless Chromium (:mod:`liquidtouch.testing.live_page`: every update reached the page,
the frames loaded, the plots were drawn, λ, ω and the properties are shown as the stream
says); the tests run the same check (``tests/live/test_live_browser.py``). Exit status 1
when a check fails.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from PIL import Image

from liquidtouch.testing.live_page import run_check, simulated_trial


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path, help="work directory (trial, model)")
    parser.add_argument("--png", type=Path, default=None, help="screenshot (default OUT/live.png)")
    parser.add_argument(
        "--palette", type=int, default=0, help="then save the PNG with this many colours (docs)"
    )
    args = parser.parse_args()
    started = time.monotonic()
    trial = simulated_trial(args.out)
    check = run_check(trial, args.png or args.out / "live.png")
    print(
        f"updates {check.updates}, signal points {check.signal_points}, frames loaded "
        f"{check.frames_loaded}, screenshot colours {check.colours}, "
        f"{time.monotonic() - started:.1f} s; screenshot {check.png}"
    )
    if args.palette:
        with Image.open(check.png) as im:  # an octree palette keeps the green arrows;
            rgb = im.convert("RGB")  # dithering keeps the gel's shading free of bands
        palette = rgb.quantize(colors=args.palette, method=Image.Quantize.FASTOCTREE)
        small = rgb.quantize(palette=palette, dither=Image.Dither.FLOYDSTEINBERG)
        small.save(check.png, optimize=True)
    for problem in check.problems:
        print("problem:", problem)
    return 1 if check.problems else 0


if __name__ == "__main__":
    sys.exit(main())
