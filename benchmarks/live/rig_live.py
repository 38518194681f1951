"""`live` watching the simulated rig's cameras while `run-trial` runs a trial (issue 21):
how often the standing estimate is right, over many runs.

    .venv/bin/python benchmarks/live/rig_live.py [--runs 10] [--seed 0] [--json runs.json]

Each run (:func:`liquidtouch.testing.rig_runs.run_once`) starts ``live`` on the rig's two
MJPEG streams before ``run-trial``, once the bottle is lifted or when the push starts
(the first three runs one of each, then at random), stops it a few seconds after the
bottle is released and compares its final update with the rig's truth: right (λ within
5 %, ω within 1 %), "no ring-down found", or wrong. ``tests/live/test_live_rig.py`` runs
one or two.
"""

from __future__ import annotations

import argparse
import json
import random
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from liquidtouch.testing.rig_runs import STARTS, rig_serving, run_once


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=10)
    parser.add_argument("--seed", type=int, default=0, help="of the random start moments")
    parser.add_argument("--hold", type=float, default=9.0, help="run-trial --seconds")
    parser.add_argument("--json", type=Path, help="write every run's summary here")
    args = parser.parse_args()
    rng = random.Random(args.seed)
    rows = []
    with rig_serving() as endpoints, tempfile.TemporaryDirectory() as tmp:
        for k in range(args.runs):
            start = STARTS[k % len(STARTS)] if k < len(STARTS) else rng.choice(STARTS)
            began = time.monotonic()
            row = run_once(endpoints, start, Path(tmp) / f"trial{k}", hold_s=args.hold)
            row["seconds"] = time.monotonic() - began
            rows.append(row)
            print(json.dumps({key: row[key] for key in row if key != "events"}), flush=True)
    right = [r for r in rows if r["outcome"] == "right"]
    print(f"{len(right)}/{len(rows)} right, "
          f"{sum(r['outcome'] == 'none found' for r in rows)} none found, "
          f"{sum(r['outcome'] == 'wrong' for r in rows)} wrong")  # fmt: skip
    if right:
        lam = np.array([r["err_decay_rate"] for r in right]) * 100
        om = np.array([r["err_angular_frequency"] for r in right]) * 100
        print(f"λ error {lam.min():+.1f} .. {lam.max():+.1f} % (median {np.median(lam):+.1f}), "
              f"ω error {om.min():+.2f} .. {om.max():+.2f} %")  # fmt: skip
    if args.json:
        args.json.write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
