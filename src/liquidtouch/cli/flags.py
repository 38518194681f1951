"""The command-line flag of each library parameter that error messages name.

The library's errors name the Python parameter (``calibration_group``), as a notebook
calls it; the command line shows the flag the user typed (``--calibration-group``).
:func:`name_flags` rewrites a message where the CLI turns an error into one line. Only
parameter names with an underscore are listed: a plain word (``split``, ``topic``)
would also match ordinary prose.
"""

from __future__ import annotations

import re

PARAMETER_FLAGS = {
    "calibration_group": "--calibration-group",
}

_NAMES = re.compile(r"(?<![\w-])(" + "|".join(map(re.escape, PARAMETER_FLAGS)) + r")(?![\w-])")


def name_flags(message: str) -> str:
    """``message`` with each parameter of :data:`PARAMETER_FLAGS` replaced by its flag."""
    return _NAMES.sub(lambda match: PARAMETER_FLAGS[match.group(1)], message)
