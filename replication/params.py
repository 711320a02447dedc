"""Checks of the scalar settings that the library's functions take (not of their data).

A string, None or a float where a number or a count is expected would otherwise fail deep in
numpy or scipy with their own message (``'<' not supported between 'str' and 'int'``), or
worse, run: ``sample_shape=(0, 5)`` silently gave no pairing. Each check raises
:class:`~replication.errors.InputError` naming the setting and the value it got.
"""

from __future__ import annotations

import math
import numbers
from typing import Any

import numpy as np

from replication.errors import InputError

__all__ = ["count", "count_pair", "generator", "real"]


def real(value: Any, name: str) -> float:
    """``value`` as a finite float; a bool, a string, None or NaN is refused."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real) or not math.isfinite(value):
        raise InputError(f"{name} must be a finite real number, got {value!r}")
    return float(value)


def count(value: Any, name: str, minimum: int = 1) -> int:
    """``value`` as a Python int of at least ``minimum``; a float such as 2.5 is refused."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < minimum:
        raise InputError(f"{name} must be an integer of at least {minimum}, got {value!r}")
    return int(value)


def count_pair(value: Any, name: str, minimum: int = 1) -> tuple[int, int]:
    """``value`` as a pair of ints, each at least ``minimum`` (a grid or net shape)."""
    if isinstance(value, (str, bytes)) or not hasattr(value, "__len__") or len(value) != 2:
        raise InputError(f"{name} must be a pair of integers, got {value!r}")
    try:
        return count(value[0], name, minimum), count(value[1], name, minimum)
    except InputError:
        raise InputError(f"{name} must be two integers of at least {minimum}, got {tuple(value)!r}") from None


def generator(rng: Any) -> np.random.Generator:
    """``np.random.default_rng(rng)`` for a seed, a Generator or None, with an InputError naming
    anything else: a negative seed, a float, or a bool (numpy takes ``True`` for seed 1)."""
    why = f"rng must be a seed (a non-negative integer), a Generator or None, got {rng!r}"
    if isinstance(rng, bool) or (isinstance(rng, numbers.Integral) and rng < 0):
        raise InputError(why)
    try:
        return np.random.default_rng(rng)
    except (TypeError, ValueError) as exc:
        raise InputError(why) from exc
