"""Double-double arithmetic (a number as an unevaluated sum hi + lo of two floats, ~32 digits),
for the phases of the exact solutions, which grow linearly in time: without it, a phase of 10⁶ rad
keeps only ~1e-10 rad of absolute precision.  Works on floats and numpy arrays alike."""

from __future__ import annotations

from decimal import Decimal

DD = tuple  # (hi, lo): floats or arrays

_SPLITTER = 134217729.0  # 2**27 + 1


def two_sum(a, b):
    """s + e = a + b exactly (Knuth)."""
    s = a + b
    bb = s - a
    return s, (a - (s - bb)) + (b - bb)


def split(a):
    """hi + lo = a with hi holding the upper 26 bits (Veltkamp)."""
    c = _SPLITTER * a
    hi = c - (c - a)
    return hi, a - hi


def two_prod(a, b):
    """p + e = a · b exactly (Dekker)."""
    p = a * b
    ah, al = split(a)
    bh, bl = split(b)
    return p, ((ah * bh - p) + ah * bl + al * bh) + al * bl


def from_decimal(x: Decimal) -> DD:
    """The double-double nearest to a high-precision Decimal."""
    hi = float(x)
    return hi, float(x - Decimal(hi))
