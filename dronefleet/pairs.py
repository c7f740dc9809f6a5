"""Paired differences, the rule the studies' verdicts share (docs/items-paper-checklist.md,
docs/lunar-thesis-checklist.md): two conditions are compared on per-run values paired by the
index both hold (a run index, or a cell and trial under common random numbers), and a
difference agrees only beyond twice its standard error."""

from __future__ import annotations

import math

import pandas as pd

__all__ = ["paired"]


def paired(a: pd.Series, b: pd.Series) -> tuple[float, float, int]:
    """(mean, standard error, n) of ``a - b`` over the index values both hold a value for;
    (nan, nan, 0) without any, standard error infinite with one."""
    d = (a - b).dropna()
    n = len(d)
    if n == 0:
        return math.nan, math.nan, 0
    return float(d.mean()), float(d.std(ddof=1) / math.sqrt(n)) if n > 1 else math.inf, n
