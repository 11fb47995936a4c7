"""Torque CSV files as plants export them, read into SI arrays.

The layout (encoding, separator, decimal mark, lines above the header, a units line, the time
and torque columns and their units) is given by the caller or sniffed:

* encoding: a byte-order mark (UTF-8, e.g. Excel's "CSV UTF-8", or UTF-16), else UTF-8, else
  latin-1; a NUL byte means binary data, not text;
* separator: tab, ``;``, ``,`` or ``|``, whichever splits most of the first lines into two or
  more fields (in that order on a tie, so ``0,01;265,3`` is split at ``;``);
* decimal mark: ``,`` when the separator is not ``,`` and a number is written ``0,01``;
* header: the last line above the first numeric row with two or more fields; earlier lines
  (titles) are ignored; a line of units (``s;Nm`` or ``[s];[kN m]``) next to it gives the
  units of its columns;
* columns: ``time_s`` and ``torque_Nm``, else one named like a time (``Time``, ``t``, ``Zeit``,
  ``Timestamp`` ...) and one like a torque (``Torque``, ``Drehmoment``, ``Moment`` ...);
* units: in the header (``Time [ms]``, ``Torque (kN m)``, ``t/s``, ``torque_kNm``) or the units
  line; ISO 8601 date-times in the time column are read as seconds since the first one.

Numbers are ASCII decimals (``[+-]digits[.digits][e[+-]digits]``, or nan/inf, refused later
as not finite); ``1_0``, Unicode digits and thousands separators are refused, as is a row with
more fields than the header.
"""

from __future__ import annotations

import codecs
import csv
import io
import json
import re
import warnings
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .._samples import RecordError, bad_option

__all__ = ["TIME_UNITS", "TORQUE_UNITS", "ISO_TIME", "CsvOptions", "parse_meta", "read_torque_csv"]

# unit -> (multiplier, divisor) to SI: a division by 1000 keeps "10" ms exactly 0.01 s
TIME_UNITS: dict[str, tuple[float, float]] = {"s": (1.0, 1.0), "ms": (1.0, 1000.0),
                                              "min": (60.0, 1.0), "h": (3600.0, 1.0)}
TORQUE_UNITS: dict[str, tuple[float, float]] = {"N m": (1.0, 1.0), "kN m": (1000.0, 1.0),
                                                "MN m": (1.0e6, 1.0)}
ISO_TIME = "iso"  # time_unit of ISO 8601 date-times
NATIVE = {"time": "time_s", "torque": "torque_Nm"}
META_PREFIX = "# meta:"
MAX_PREAMBLE_LINES = 100  # lines searched for the header and the first numeric row
SEPARATORS = ("\t", ";", ",", "|")

_TIME_ALIASES = {"s": "s", "sec": "s", "secs": "s", "second": "s", "seconds": "s",
                 "ms": "ms", "msec": "ms", "millisecond": "ms", "milliseconds": "ms",
                 "min": "min", "minute": "min", "minutes": "min", "h": "h", "hour": "h",
                 "hours": "h", ISO_TIME: ISO_TIME}
_TORQUE_ALIASES = {"Nm": "N m", "NM": "N m", "nm": "N m", "kNm": "kN m", "KNm": "kN m",
                   "knm": "kN m", "kNM": "kN m", "MNm": "MN m"}
_TIME_NAMES = re.compile(r"t|time.*|zeit|timestamp|time ?stamp|date ?time|date|zeitstempel|"
                         r"temps|tiempo|tempo", re.IGNORECASE)
_TORQUE_NAMES = re.compile(r".*(torque|drehmoment|moment|couple).*|m_?d", re.IGNORECASE)
_NAME_UNIT = (re.compile(r"(?P<name>.*?)\s*\[(?P<unit>[^\]]*)\]"),
              re.compile(r"(?P<name>.*?)\s*\((?P<unit>[^)]*)\)"),
              re.compile(r"(?P<name>.*?)\s+in\s+(?P<unit>\S+)", re.IGNORECASE),
              re.compile(r"(?P<name>.*?)\s*/\s*(?P<unit>[^/]+)"),
              re.compile(r"(?P<name>.*?),\s*(?P<unit>\S+)"),
              re.compile(r"(?P<name>.+)_(?P<unit>[A-Za-z]+)"))
_ISO = re.compile(r"[0-9]{4}-[0-9]{2}-[0-9]{2}(?:[T ][0-9]{2}:[0-9]{2}(?::[0-9]{2}(?:\.[0-9]+)?)?"
                  r"(?:Z|[+-][0-9]{2}:?[0-9]{2})?)?")


def _number_pattern(decimal: str) -> re.Pattern[str]:
    """ASCII decimal numbers with ``decimal`` as the decimal mark, or nan/inf."""
    d = re.escape(decimal)
    return re.compile(rf"[+-]?(?:[0-9]+(?:{d}[0-9]*)?|{d}[0-9]+)(?:[eE][+-]?[0-9]+)?"
                      r"|[+-]?(?:nan|inf|infinity)", re.IGNORECASE)


_ANY_NUMBER = re.compile(rf"{_number_pattern('.').pattern}|{_number_pattern(',').pattern}",
                         re.IGNORECASE)
_COMMA_DECIMAL = re.compile(r"[+-]?[0-9]*,[0-9]+(?:[eE][+-]?[0-9]+)?")


def _quoted(text: str, limit: int = 40) -> str:
    """``repr(text)`` for a message: of its first ``limit`` characters, then how many more."""
    return repr(text) if len(text) <= limit else f"{text[:limit]!r}... ({len(text)} characters)"


def canonical_unit(text: str, kind: str) -> str | None:
    """The unit ``text`` as a key of TIME_UNITS (or ISO_TIME) / TORQUE_UNITS, or None."""
    cleaned = text.strip().strip("[]()").strip()
    if kind == "time":
        return _TIME_ALIASES.get(cleaned.lower())
    joined = re.sub(r"[\s·⋅*.\-]", "", cleaned)
    if joined in _TORQUE_ALIASES:
        return _TORQUE_ALIASES[joined]
    return cleaned if cleaned in TORQUE_UNITS else None


@dataclass(frozen=True)
class CsvOptions:
    """How to read a torque CSV; None means sniffed (see the module docstring).

    Parameters
    ----------
    time_column, torque_column : str or int, optional
        The column, by header name (exact, or without its unit, case-insensitive) or by index
        from 0.
    time_unit : {"s", "ms", "min", "h", "iso"}, optional
        Unit of the time column ("iso": ISO 8601 date-times).
    torque_unit : {"N m", "kN m", "MN m"}, optional
        Unit of the torque column (``Nm``, ``kNm``, ``MNm`` are accepted too).
    sep : str, optional
        Field separator, one character.
    decimal : {".", ","}, optional
        Decimal mark.
    skiprows : int, optional
        Lines at the top of the file to skip before looking for the header.
    encoding : str, optional
        Text encoding (a Python codec name, e.g. ``"latin-1"``).
    """

    time_column: str | int | None = None
    torque_column: str | int | None = None
    time_unit: str | None = None
    torque_unit: str | None = None
    sep: str | None = None
    decimal: str | None = None
    skiprows: int | None = None
    encoding: str | None = None

    def __post_init__(self) -> None:
        for name in ("time_column", "torque_column"):
            value = getattr(self, name)
            if value is None:
                continue
            if isinstance(value, bool) or not isinstance(value, (str, int)) or (
                    isinstance(value, int) and value < 0) or (
                    isinstance(value, str) and not value.strip()):
                raise bad_option(name, value, "a column name or an index >= 0")
        for name, kind, valid in (("time_unit", "time", [*TIME_UNITS, ISO_TIME]),
                                  ("torque_unit", "torque", list(TORQUE_UNITS))):
            value = getattr(self, name)
            if value is None:
                continue
            unit = canonical_unit(value, kind) if isinstance(value, str) else None
            if unit is None:
                raise bad_option(name, value, f"one of {', '.join(map(repr, valid))}")
            object.__setattr__(self, name, unit)
        if self.decimal is not None and self.decimal not in (".", ","):
            raise bad_option("decimal", self.decimal, "'.' or ','")
        if self.sep is not None and not (isinstance(self.sep, str) and len(self.sep) == 1
                                         and self.sep not in "\"\r\n.0123456789"
                                         and self.sep != self.decimal):
            raise bad_option("sep", self.sep, "one character other than a digit, '.', a quote, a "
                                         "line break or the decimal mark")
        if self.skiprows is not None and (isinstance(self.skiprows, bool) or not isinstance(
                self.skiprows, int) or self.skiprows < 0):
            raise bad_option("skiprows", self.skiprows, "an integer >= 0")
        if self.encoding is not None:
            try:
                codecs.lookup(self.encoding)
            except (LookupError, TypeError):
                raise bad_option("encoding", self.encoding, "a text encoding Python knows, e.g. "
                                                       "'utf-8' or 'latin-1'") from None


@dataclass(frozen=True)
class _Column:
    index: int
    header: str  # the header cell, or "column <i>" without a header
    unit: str


def _decode(raw: bytes, encoding: str | None, where: str) -> str:
    """The file's text: in ``encoding`` if given, else sniffed; the BOM dropped."""
    if encoding is None:
        if raw.startswith(codecs.BOM_UTF8):
            encoding = "utf-8-sig"
        elif raw.startswith((codecs.BOM_UTF16_LE, codecs.BOM_UTF16_BE)):
            encoding = "utf-16"
        else:
            try:
                return raw.decode("utf-8")
            except UnicodeDecodeError:
                return raw.decode("latin-1")  # every byte is a latin-1 character
    try:
        return raw.decode(encoding).removeprefix("\ufeff")
    except UnicodeDecodeError as exc:
        raise RecordError(f"{where}: not {encoding} text: byte {exc.start} is "
                          f"{raw[exc.start]:#04x}; give the file's encoding "
                          "(e.g. encoding='latin-1')") from None


def parse_meta(text: str, where: str) -> dict[str, Any]:
    """The JSON object in ``text`` (a record's meta); anything else raises RecordError."""
    try:
        meta = json.loads(text)
    except ValueError as exc:  # JSONDecodeError, or an integer of over 4300 digits
        raise RecordError(f"{where}: meta is not valid JSON ({_quoted(str(exc), 200)})") from None
    except RecursionError:
        raise RecordError(f"{where}: meta is nested too deeply to read") from None
    if not isinstance(meta, Mapping):
        raise RecordError(f"{where}: meta must be a JSON object {{...}}; got "
                          f"{type(meta).__name__} {_quoted(json.dumps(meta))}")
    return dict(meta)


def _split(line: str, sep: str, where: str) -> list[str]:
    """The fields of one line (quotes as pandas reads them)."""
    if '"' not in line:
        return line.split(sep)
    try:
        return next(csv.reader([line], delimiter=sep))
    except csv.Error as exc:  # a quoted field over csv's limit of 131,072 characters
        raise RecordError(f"{where}: {exc}") from None


def _sniff_sep(lines: list[str]) -> str:
    """The separator that splits most of ``lines`` into two or more fields."""
    counts = [sum(s in line for line in lines) for s in SEPARATORS]
    best = max(range(len(SEPARATORS)), key=lambda i: (counts[i], -i))
    return SEPARATORS[best] if counts[best] else ","


def _python_number(cell: str) -> bool:
    """What Python's float() reads (also '1_0' and other scripts' digits, refused later)."""
    try:
        float(cell.replace(",", "."))
    except ValueError:
        return False
    return True


def _is_data(fields: list[str]) -> bool:
    """A row of two or more fields, numbers (one at least in ASCII) and ISO date-times."""
    cells = [f.strip() for f in fields if f.strip()]
    return (len(fields) >= 2 and any(_ANY_NUMBER.fullmatch(c) for c in cells)
            and all(_ISO.fullmatch(c) or _python_number(c) for c in cells))


def _is_units_row(fields: list[str]) -> bool:
    """A row of short unit strings, at least one a time or torque unit."""
    cells = [f.strip() for f in fields if f.strip()]
    return bool(cells) and all(len(c) <= 12 for c in cells) and any(
        canonical_unit(c, "time") not in (None, ISO_TIME) or canonical_unit(c, "torque")
        for c in cells)


def _name_and_unit(cell: str) -> tuple[str, str | None]:
    """``"Torque [kN m]"`` -> ("Torque", "kN m"); a snake suffix counts only when a unit."""
    cell = cell.strip()
    for pattern in _NAME_UNIT:
        match = pattern.fullmatch(cell)
        if match and match["name"]:
            unit = match["unit"].strip()
            if pattern is _NAME_UNIT[-1] and not (canonical_unit(unit, "time")
                                                  or canonical_unit(unit, "torque")):
                continue
            return match["name"].strip(), unit
    return cell, None


def _pick(kind: str, spec: str | int | None, header: list[str] | None, other: int | None,
          where: str) -> int:
    """The index of the ``kind`` ("time"/"torque") column."""
    option = f"{kind}_column"
    if header is None:
        if not isinstance(spec, int):
            raise RecordError(
                f"{where}: no header line; expected columns {NATIVE['time']},"
                f"{NATIVE['torque']} (or give time_column and torque_column as indices from 0)")
        return spec
    names = [_name_and_unit(h)[0] for h in header]
    if isinstance(spec, int):
        return spec  # checked against the data's width
    if isinstance(spec, str):
        wanted = spec.strip()
        hits = [i for i, h in enumerate(header) if h == wanted]
        if len(hits) != 1:  # the name without its unit, in any case
            hits = [i for i, n in enumerate(names) if n.lower() == wanted.lower()]
        if len(hits) == 1:
            return hits[0]
        raise RecordError(f"{where}: {option} = {spec!r} is not one column of the header "
                          f"{header}")
    if NATIVE[kind] in header:
        return header.index(NATIVE[kind])
    pattern = _TIME_NAMES if kind == "time" else _TORQUE_NAMES
    hits = [i for i, n in enumerate(names) if pattern.fullmatch(n) and i != other]
    if len(hits) == 1:
        return hits[0]
    if not hits and other is not None and len(header) == 2:
        return 1 - other
    found = "several columns" if hits else "no column"
    raise RecordError(f"{where}: missing column {NATIVE[kind]!r}; {found} named like a {kind} "
                      f"in {header}; give {option} (a name or an index from 0)")


def _unit(kind: str, option: str | None, index: int, header: list[str] | None,
          units_row: list[str] | None, first_value: str, where: str) -> _Column:
    """The column with its unit: the option, the header's, the units line's, or ISO dates."""
    label = f"column {index}" if header is None else header[index]
    text = None if header is None else _name_and_unit(header[index])[1]
    if text is None and units_row is not None and index < len(units_row):
        text = units_row[index].strip() or None
    found = None if text is None else canonical_unit(text, kind)
    if option is not None:
        if found is not None and found != option:
            raise RecordError(f"{where}: {kind}_unit = {option!r} contradicts the unit "
                              f"{text!r} the file gives for column {label!r}")
        return _Column(index, label, option)
    if found is not None:
        return _Column(index, label, found)
    if kind == "time" and _ISO.fullmatch(first_value.strip()) and not _ANY_NUMBER.fullmatch(
            first_value.strip()):
        return _Column(index, label, ISO_TIME)
    valid = ", ".join(map(repr, [*TIME_UNITS, ISO_TIME] if kind == "time" else TORQUE_UNITS))
    said = "no unit" if text is None else f"the unit {text!r}, which is not one of {valid}"
    raise RecordError(f"{where}: missing column {NATIVE[kind]!r}: column {label!r} has {said}; "
                      f"give {kind}_unit ({valid}) or a header like "
                      f"'{kind.capitalize()} [{'s' if kind == 'time' else 'N m'}]'")


def _numbers(cells: Any, decimal: str, lines: NDArray[np.int64], column: _Column,
             where: str) -> NDArray[np.float64]:
    """The cells (a pandas Series of str) as floats; the first cell that is not an ASCII
    number raises, naming its line."""
    stripped = cells.str.strip()
    good = stripped.str.fullmatch(_number_pattern(decimal)).to_numpy(dtype=bool)
    if not good.all():
        i = int(np.flatnonzero(~good)[0])
        value = str(stripped.iloc[i])
        what = " is missing or empty" if not value else f": {_quoted(value)} is not a number"
        hint = "" if not value or decimal == "," or not _COMMA_DECIMAL.fullmatch(value) else (
            " (a decimal comma? give decimal=',')")
        raise RecordError(f"{where} line {lines[i]}: column {column.header!r}{what}{hint}")
    if decimal == ",":
        stripped = stripped.str.replace(",", ".", regex=False)
    return np.asarray(stripped.astype(float).to_numpy(), dtype=np.float64)


def _seconds(cells: Any, lines: NDArray[np.int64], column: _Column,
             where: str) -> tuple[NDArray[np.float64], str]:
    """ISO 8601 date-times as seconds since the first, and the first as text."""
    import pandas as pd

    stamps = pd.to_datetime(cells.str.strip(), format="ISO8601", utc=True, errors="coerce")
    bad = np.flatnonzero(stamps.isna().to_numpy())
    if bad.size:
        i = int(bad[0])
        raise RecordError(f"{where} line {lines[i]}: column {column.header!r}: "
                          f"{_quoted(str(cells.iloc[i]))} is not an ISO 8601 date-time")
    seconds = (stamps - stamps.iloc[0]).dt.total_seconds().to_numpy(dtype=np.float64)
    return seconds, str(cells.iloc[0]).strip()


def _to_si(values: NDArray[np.float64], unit: str, table: dict[str, tuple[float, float]]
           ) -> NDArray[np.float64]:
    multiplier, divisor = table[unit]
    return values * multiplier / divisor


@dataclass(frozen=True)
class _Layout:
    """Where the parts of a file are: the separator, the header (None without one) and its
    line number, the units line, and the first data row (an index into the content lines)."""

    sep: str
    header: list[str] | None
    header_line: int | None
    units_row: list[str] | None
    start: int
    first_row: list[str]


def _content(text: str, skiprows: int, where: str) -> tuple[list[str], list[int], dict[str, Any]]:
    """(all lines, the indices of those holding fields, the meta of a ``# meta:`` line):
    blank lines, comments and the first ``skiprows`` lines hold no fields."""
    lines = text.replace("\r\n", "\n").replace("\r", "\n").split("\n")
    meta: dict[str, Any] = {}
    kept: list[int] = []
    for i, line in enumerate(lines):
        if "\0" in line:
            raise RecordError(f"{where}: binary data (a NUL character on line {i + 1}), not a "
                              "text file; a torque CSV is text (.npz records are zip files)")
        stripped = line.strip()
        if not stripped or i < skiprows:
            continue
        if stripped.startswith(META_PREFIX):
            meta = parse_meta(stripped[len(META_PREFIX):], f"{where} line {i + 1}")
        elif not stripped.startswith("#"):
            kept.append(i)
    return lines, kept, meta


def _layout(lines: list[str], kept: list[int], sep: str | None, where: str) -> _Layout:
    """The separator, header, units line and first data row, found in the first lines."""
    head = kept[:MAX_PREAMBLE_LINES]
    sep = sep or _sniff_sep([lines[i] for i in head])
    rows = [_split(lines[i], sep, f"{where} line {i + 1}") for i in head]
    start = next((k for k, fields in enumerate(rows) if _is_data(fields)), None)
    if start is None:
        if len(kept) > len(head):
            raise RecordError(f"{where}: no row of numbers in the first {len(head)} lines; give "
                              "skiprows (the lines above the header)")
        start = len(rows)
    preamble = [k for k in range(start) if len(rows[k]) >= 2]  # titles have one field
    if not preamble:
        if start == len(rows):
            raise RecordError(f"{where}: no header line; expected columns "
                              f"{NATIVE['time']},{NATIVE['torque']}")
        return _Layout(sep, None, None, None, start, rows[start])
    header_k, units_k = preamble[-1], None
    if len(preamble) >= 2:  # a units line just above or below the header
        above, below = (_is_units_row(rows[k]) for k in preamble[-2:])
        if above != below:
            header_k, units_k = (preamble[-2], preamble[-1]) if below else (preamble[-1],
                                                                            preamble[-2])
    return _Layout(sep, [h.strip() for h in rows[header_k]], head[header_k] + 1,
                   None if units_k is None else rows[units_k], start,
                   rows[start] if start < len(rows) else [])


def _table(lines: list[str], data: list[int], layout: _Layout, columns: int,
           where: str) -> Any:
    """The data rows as a pandas DataFrame of str, ``columns`` wide; a longer row raises."""
    import pandas as pd

    limit = ("the first data row" if layout.header is None else
             f"the {len(layout.header)} of the header (line {layout.header_line})")
    block = "\n".join(lines[i] for i in data)
    if '"' in block:  # a quote left open would join lines into one field
        odd = next((i for i in data if lines[i].count('"') % 2), None)
        if odd is not None:
            raise RecordError(f"{where} line {odd + 1}: a quote \" is not closed on its line")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", pd.errors.ParserWarning)
            # not usecols: with it, pandas drops the fields of a row longer than the header
            frame = pd.read_csv(io.StringIO(block), sep=layout.sep, header=None,
                                names=range(columns), dtype=str, index_col=False,
                                na_filter=False, engine="c", quotechar='"')
    except pd.errors.ParserWarning as exc:
        raise RecordError(f"{where}: {exc}") from None
    except pd.errors.ParserError as exc:
        message = str(exc).strip().splitlines()[-1]
        match = re.search(r"Expected \d+ fields in line (\d+), saw (\d+)", message)
        if match:
            raise RecordError(f"{where} line {data[int(match[1]) - 1] + 1}: {match[2]} fields, "
                              f"more than {limit}") from None
        raise RecordError(f"{where}: {message}") from None
    if len(frame) != len(data):
        raise RecordError(f"{where}: {len(data)} data lines read as {len(frame)} rows")
    width = columns if layout.header is None else len(layout.header)
    for c in range(width, columns):  # beyond the header, only empty fields (a trailing sep)
        filled = np.flatnonzero(frame[c].str.strip().to_numpy() != "")
        if filled.size:
            raise RecordError(f"{where} line {data[int(filled[0])] + 1}: more fields than "
                              f"{limit}")
    return frame


def read_torque_csv(path: Path, options: CsvOptions) -> tuple[
        NDArray[np.float64], NDArray[np.float64], dict[str, Any]]:
    """(time in s, torque in N m, meta) of a torque CSV file; RecordError names the file and
    line of any problem."""
    where = str(path)
    text = _decode(path.read_bytes(), options.encoding, where)
    lines, kept, meta = _content(text, options.skiprows or 0, where)
    layout = _layout(lines, kept, options.sep, where)
    header = layout.header
    at = where if layout.header_line is None else f"{where} line {layout.header_line}"
    time_index = _pick("time", options.time_column, header, None, at)
    torque_index = _pick("torque", options.torque_column, header, time_index, at)
    if time_index == torque_index:
        raise RecordError(f"{at}: time and torque are the same column {time_index}")
    data = kept[layout.start:]
    if not data:
        raise RecordError(f"{at}: no data rows under the header; a record needs at least 2 "
                          "samples")
    first = layout.first_row
    columns = max(len(first), len(header or []))
    for option, index in (("time_column", time_index), ("torque_column", torque_index)):
        if index >= columns:
            raise RecordError(f"{at}: {option} = {index} is not valid; it must be an index in "
                              f"0..{columns - 1}, the columns {header or first}")
    time_col = _unit("time", options.time_unit, time_index, header, layout.units_row,
                     first[time_index] if time_index < len(first) else "", at)
    torque_col = _unit("torque", options.torque_unit, torque_index, header, layout.units_row,
                       first[torque_index] if torque_index < len(first) else "", at)
    sample = [f.strip() for i in data[:MAX_PREAMBLE_LINES]
              for f in _split(lines[i], layout.sep, f"{where} line {i + 1}")]
    decimal = options.decimal or (
        "," if layout.sep != "," and any(_COMMA_DECIMAL.fullmatch(f) for f in sample) else ".")
    if decimal == layout.sep:
        raise RecordError(f"{where}: decimal = {decimal!r} is the separator too; give sep")
    frame = _table(lines, data, layout, columns, where)
    line_numbers = np.asarray(data, dtype=np.int64) + 1
    if time_col.unit == ISO_TIME:
        time, origin = _seconds(frame[time_index], line_numbers, time_col, where)
        meta = {**meta, "time_origin": origin}
    else:
        time = _to_si(_numbers(frame[time_index], decimal, line_numbers, time_col, where),
                      time_col.unit, TIME_UNITS)
    torque = _to_si(_numbers(frame[torque_index], decimal, line_numbers, torque_col, where),
                    torque_col.unit, TORQUE_UNITS)
    return time, torque, meta
