"""Result tables as pandas DataFrames: the one builder behind every ``to_frame()``, and the
CSV and JSON text of a frame (the command line's ``--format``).

pandas is imported on first use, not with millscope: it takes longer to import than the rest
of the analysis side together.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any, Literal

if TYPE_CHECKING:
    from pandas import DataFrame

__all__ = ["FORMATS", "Kind", "frame", "frame_text"]

#: The ``--format`` choices of the command line: text (the command's own lines), CSV, JSON.
FORMATS = ("text", "csv", "json")

#: How a column is stored: "int" (int64, or pandas' nullable Int64 when a value is missing),
#: "level" (as "int" when every value is a whole number, else float64), "float" (float64,
#: nan when missing), "bool" and "str" (pandas' string type of the installed version).
Kind = Literal["int", "level", "float", "bool", "str"]


def _integral(values: Sequence[Any]) -> bool:
    return all(v is None or (isinstance(v, (int, float)) and not isinstance(v, bool)
                             and math.isfinite(v) and float(v).is_integer()) for v in values)


def frame(columns: Mapping[str, Kind], rows: Sequence[Mapping[str, Any]]) -> DataFrame:
    """A DataFrame of ``rows`` (one mapping per row) with the ``columns`` in this order, each
    stored as its kind says; a key a row lacks is a missing value (None)."""
    import pandas as pd

    data: dict[str, Any] = {}
    for name, kind in columns.items():
        values = [row.get(name) for row in rows]
        if kind == "level" and not _integral(values):
            kind = "float"
        elif kind == "level":
            kind = "int"
        if kind == "int":
            whole = [None if v is None else int(v) for v in values]
            data[name] = pd.array(whole, dtype="Int64" if None in whole else "int64")
        elif kind == "float":
            data[name] = pd.array([math.nan if v is None else float(v) for v in values],
                                  dtype="float64")
        elif kind == "bool":
            data[name] = pd.array([bool(v) for v in values], dtype="bool")
        else:
            data[name] = pd.Series([None if v is None else str(v) for v in values],
                                   dtype=None if values else object)
    return pd.DataFrame(data, columns=list(columns))


def frame_text(table: DataFrame, fmt: str) -> str:
    """``table`` as CSV (pandas ``to_csv``: a header line, floats written exactly, missing
    values empty) or JSON (a list of records, one object per row and per line, as pandas'
    ``orient="records"``; floats written exactly, missing and non-finite values null).

    pandas' own ``to_json`` writes at most 15 significant digits; the records are written by
    :func:`json.dumps` instead, which writes each float so that it reads back exactly.
    """
    if fmt == "csv":
        return str(table.to_csv(index=False, lineterminator="\n"))
    if fmt == "json":
        import pandas as pd

        def plain(value: Any) -> Any:  # JSON has neither nan nor infinity: null
            if value is None or value is pd.NA or (isinstance(value, float)
                                                   and not math.isfinite(value)):
                return None
            return value

        records = [{k: plain(v) for k, v in row.items()}
                   for row in table.astype(object).to_dict(orient="records")]
        lines = ",\n".join(json.dumps(r, allow_nan=False) for r in records)
        return f"[\n{lines}\n]\n" if records else "[]\n"
    raise ValueError(f"format = {fmt!r} is not valid; it must be one of 'csv', 'json'")
