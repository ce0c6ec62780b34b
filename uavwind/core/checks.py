"""Input checks every layer uses, so bad input always fails the same way.

This module owns the small validators behind the project's promise: a bad argument gets a
``ValueError`` or ``TypeError`` that names the parameter and the allowed range, before any
work starts. :func:`check_scalar` and :func:`check_array` check numbers and arrays;
:func:`check_choice` a name among allowed ones; :func:`check_instance` a type;
:func:`check_kwargs` that a function taking ``**kwargs`` was given only keywords it knows;
:class:`Range` the allowed values of one number as a value, and :func:`check_fields` the
number fields of a frozen dataclass against a table of them, in its ``__post_init__`` (the
class's public boundary: what it holds afterwards is trusted).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, TypeVar

import numpy as np

if TYPE_CHECKING:
    from numpy.typing import ArrayLike, DTypeLike

__all__ = ["check_scalar", "check_array", "check_choice", "check_instance", "check_kwargs",
           "Range", "check_fields"]

_T = TypeVar("_T")


def check_scalar(value: float, name: str, *, low: float | None = None,
                 high: float | None = None, low_inclusive: bool = True,
                 high_inclusive: bool = True, integer: bool = False) -> float:
    """Return ``value`` as a float (or int) after checking type, finiteness and range.

    Raises
    ------
    TypeError
        If ``value`` is not a real number (bools are rejected).
    ValueError
        If ``value`` is NaN/inf or outside ``[low, high]``; the message names
        ``name`` and the allowed range.
    """
    if isinstance(value, (bool, np.bool_)) or not isinstance(
            value, (int, float, np.integer, np.floating)):
        raise TypeError(f"{name} must be a real number, got {type(value).__name__}")
    if integer:
        if not isinstance(value, (int, np.integer)):
            if not math.isfinite(float(value)):
                raise ValueError(f"{name} must be a finite integer, got {value}")
            if float(value) != int(value):
                raise TypeError(f"{name} must be an integer, got {value!r}")
        value = int(value)
    else:
        value = float(value)
        if not math.isfinite(value):
            raise ValueError(f"{name} must be finite, got {value}")
    lo_ok = low is None or (value >= low if low_inclusive else value > low)
    hi_ok = high is None or (value <= high if high_inclusive else value < high)
    if not (lo_ok and hi_ok):
        lb = "-inf" if low is None else f"{low}"
        hb = "inf" if high is None else f"{high}"
        rng = ("[" if low_inclusive and low is not None else "(") + f"{lb}, {hb}" + (
            "]" if high_inclusive and high is not None else ")")
        raise ValueError(f"{name} must be in {rng}, got {value}")
    return value


def check_array(value: ArrayLike, name: str, *, shape: Sequence[int | None] | None = None,
                ndim: int | None = None, finite: bool = True,
                dtype: DTypeLike = float) -> np.ndarray:
    """Return ``value`` as a float ndarray after checking shape and finiteness.

    ``shape`` may contain ``None`` for a free axis, e.g. ``(None, 3)``.
    """
    try:
        arr = np.asarray(value, dtype=dtype)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"{name} must be a numeric array: {exc}") from None
    if ndim is not None and arr.ndim != ndim:
        raise ValueError(f"{name} must have {ndim} dimension(s), got shape {arr.shape}")
    if shape is not None:
        if arr.ndim != len(shape) or any(
                s is not None and s != a for s, a in zip(shape, arr.shape)):
            want = "(" + ", ".join("n" if s is None else str(s) for s in shape) + ")"
            raise ValueError(f"{name} must have shape {want}, got {arr.shape}")
    if finite and arr.size and not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must contain only finite values (no NaN or inf)")
    return arr


def check_choice(value: _T, name: str, choices: Iterable) -> _T:
    """``value`` if it is one of ``choices``, else ``ValueError`` naming ``name`` and the choices.

    >>> check_choice("fast", "engine", ("fast", "tslearn"))
    'fast'
    """
    choices = list(choices)
    try:
        ok = value in choices
    except TypeError:  # an unhashable value against a dict or set
        ok = False
    if not ok:
        raise ValueError(f"{name} must be one of {choices}, got {value!r}")
    return value


def check_instance(value: _T, name: str, types: type | tuple[type, ...],
                   what: str | None = None) -> _T:
    """``value`` if it is an instance of ``types``, else ``TypeError`` naming ``name``."""
    if not isinstance(value, types):
        if what is None:
            ts = types if isinstance(types, tuple) else (types,)
            what = " or ".join(t.__name__ for t in ts)
        raise TypeError(f"{name} must be a {what}, got {type(value).__name__}")
    return value


def check_kwargs(kwargs: Mapping, allowed: Iterable, where: str) -> None:
    """``TypeError`` if ``kwargs`` holds a keyword not in ``allowed`` (python-control's habit:
    a misspelt keyword fails loudly instead of being ignored)."""
    unknown = sorted(set(kwargs) - set(allowed))
    if unknown:
        raise TypeError(f"{where} got unexpected keyword argument(s) {unknown}; "
                        f"allowed: {sorted(allowed)}")


@dataclass(frozen=True)
class Range:
    """The allowed values of one number, :func:`check_scalar`'s bounds as a value: ``[low,
    high]`` (``None``: unbounded), each end inclusive unless said otherwise, an integer if
    ``integer``.

    >>> Range(0.0, 1.0, low_inclusive=False).check(0.5, "smoothing")
    0.5
    """

    low: float | None = None
    high: float | None = None
    low_inclusive: bool = True
    high_inclusive: bool = True
    integer: bool = False

    def check(self, value: Any, name: str) -> float:
        """``value`` checked and coerced (:func:`check_scalar`)."""
        return check_scalar(value, name, low=self.low, high=self.high,
                            low_inclusive=self.low_inclusive,
                            high_inclusive=self.high_inclusive, integer=self.integer)


def check_fields(obj: Any, ranges: Mapping[str, Range | Callable[[Any], Range]],
                 label: str = "{}") -> None:
    """Check the number fields of the frozen dataclass ``obj`` named in ``ranges`` and store
    each coerced (a float, or an int where the range says ``integer``), in the table's order;
    a range may be a function of ``obj`` (``lambda s: Range(1, s.n_samples)``), which then
    sees the fields checked before it. A message names the field as ``label.format(name)``
    (``"profile[{!r}]"``: ``profile['loops']``)."""
    for name, rng in ranges.items():
        if not isinstance(rng, Range):
            rng = rng(obj)
        object.__setattr__(obj, name, rng.check(getattr(obj, name), label.format(name)))
