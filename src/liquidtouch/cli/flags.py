"""The command-line flag of each library parameter that error messages name.

The library's errors name the Python parameter in backquotes (```calibration_group```),
as a notebook calls it; the command line shows the flag the user typed
(``--calibration-group``). :func:`name_flags` rewrites a message where the CLI turns an
error into one line. A parameter has one flag in every command that takes it.
"""

from __future__ import annotations

import re

PARAMETER_FLAGS = {
    "bag": "--bag",
    "calibration_group": "--calibration-group",
    "dask_address": "--dask",
    "fps": "--fps",
    "jobs": "--jobs",
    "level": "--level",
    "link": "--link",
    "markers": "--markers",
    "model": "--model",
    "name": "--name",
    "sensor_names": "--sensor-name",
    "split": "--split",
    "time_source": "--time-source",
    "topics": "--topic",
    "where": "--where",
}

_NAMED = re.compile(r"`(\w+)`")


def name_flags(message: str) -> str:
    """``message`` with each backquoted parameter of :data:`PARAMETER_FLAGS` replaced by its
    flag (other backquoted words are left as they are)."""
    return _NAMED.sub(lambda m: PARAMETER_FLAGS.get(m.group(1), m.group(0)), message)
