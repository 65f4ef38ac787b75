"""Measurement results as plain JSON values and as tidy DataFrames (one row per measured cell)."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd


def jsonable(x):
    """Plain Python for ``json.dumps``: numpy scalars and arrays become numbers and lists,
    non-finite floats become None (JSON has no inf/nan)."""
    if isinstance(x, dict):
        return {str(k): jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return jsonable(x.tolist())
    if isinstance(x, (np.bool_, bool)):
        return bool(x)
    if isinstance(x, (np.integer,)):
        return int(x)
    if isinstance(x, (float, np.floating)):
        x = float(x)
        return x if math.isfinite(x) else None
    if isinstance(x, complex):
        return {"re": x.real, "im": x.imag}
    return x


def frame(results: list[dict]) -> pd.DataFrame:
    """Tidy table, one row per measured cell: the scalar fields of each result (nested
    dicts flattened to ``outer.inner``); lists and series are left to the JSON form."""
    rows = []
    for res in results:
        row: dict = {}
        _flatten(res, "", row)
        rows.append(row)
    return pd.DataFrame(rows)


def _flatten(d: dict, prefix: str, out: dict) -> None:
    for k, v in d.items():
        name = f"{prefix}{k}"
        if isinstance(v, dict):
            _flatten(v, name + ".", out)
        elif v is None or isinstance(v, (str, bool, int, float, np.bool_, np.integer, np.floating)):
            out[name] = v


def order_points_frame(result: dict) -> pd.DataFrame:
    """An observed-order result's timesteps, one row each, used and left out (with the reason)."""
    rows = [{**p, "used": True, "reason": None} for p in result["points"]]
    rows += [{**p, "used": False} for p in result["excluded"]]
    df = pd.DataFrame(rows)
    if len(df):
        df = df.sort_values("dt", ignore_index=True)
        df.insert(0, "method", result["method"])
        df.insert(0, "scene", result["scene"])
    return df
