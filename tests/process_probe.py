"""A function for a worker process to run that imports nothing itself: which modules the process
already had when it started."""

from __future__ import annotations

import sys


def loaded(names: list[str]) -> list[bool]:
    """Whether each of ``names`` is imported in this process."""
    return [name in sys.modules for name in names]
