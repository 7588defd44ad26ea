"""Files written atomically: a reader (or a kill mid-write) never sees a half-written file.

Each writer creates the folder if needed, writes a temporary file beside the target and renames
it over the target in one step (``os.replace``); a writer killed before the rename leaves a
temporary file named ``.<name>.<random><suffix>`` (``is_temporary``), which a resumed command
removes. Results kept between runs are written as data only (``dumps_data``: JSON with arrays,
tuples and bytes tagged), never as pickles, so reading one back runs no code.
"""

from __future__ import annotations

import base64
import contextlib
import csv
import io
import json
import math
import os
import re
import tempfile
from pathlib import Path

import numpy as np


@contextlib.contextmanager
def atomic_path(path: str | Path, suffix: str = ""):
    """Yield a temporary path beside ``path``; on success it replaces ``path``, on error it is removed."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=suffix or path.suffix, dir=path.parent)
    os.close(fd)
    os.chmod(tmp, 0o666 & ~_umask())  # mkstemp makes 0600; give the file the usual permissions
    try:
        yield Path(tmp)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def is_temporary(path: str | Path) -> bool:
    """Whether ``path`` is a temporary file ``atomic_path`` left behind (its writer was killed)."""
    return re.fullmatch(r"\..+\.[A-Za-z0-9_]{8}(\.\w+)?", Path(path).name) is not None


def remove_temporary(folder: str | Path) -> int:
    """Remove the temporary files ``atomic_path`` left in ``folder`` and its subfolders; returns how many."""
    removed = 0
    for path in Path(folder).rglob(".*"):
        if path.is_file() and is_temporary(path):
            path.unlink(missing_ok=True)
            removed += 1
    return removed


def _encode(obj):
    if isinstance(obj, np.ndarray):
        if obj.dtype.kind not in "biufc":
            raise TypeError(f"an array of dtype {obj.dtype} is not data")
        return {"__ndarray__": [obj.dtype.str, list(obj.shape),
                                base64.b64encode(np.ascontiguousarray(obj).tobytes()).decode()]}
    if isinstance(obj, np.generic):
        return _encode(obj.item())
    if isinstance(obj, tuple):
        return {"__tuple__": [_encode(v) for v in obj]}
    if isinstance(obj, list):
        return [_encode(v) for v in obj]
    if isinstance(obj, (bytes, bytearray)):
        return {"__bytes__": base64.b64encode(bytes(obj)).decode()}
    if isinstance(obj, dict):
        if all(isinstance(k, str) and not k.startswith("__") for k in obj):
            return {k: _encode(v) for k, v in obj.items()}
        return {"__dict__": [[_encode(k), _encode(v)] for k, v in obj.items()]}
    if obj is None or isinstance(obj, (bool, int, float, str)):
        return obj
    raise TypeError(f"a {type(obj).__name__} is not data (arrays, numbers, strings, lists, tuples, dicts, bytes)")


def _decode(obj):
    if isinstance(obj, list):
        return [_decode(v) for v in obj]
    if isinstance(obj, dict):
        if len(obj) == 1:
            (tag, value), = obj.items()
            if tag == "__ndarray__":
                dtype, shape, data = value
                if np.dtype(dtype).kind not in "biufc":
                    raise ValueError(f"an array of dtype {dtype} is not data")
                return np.frombuffer(base64.b64decode(data), dtype=np.dtype(dtype)).reshape(shape).copy()
            if tag == "__tuple__":
                return tuple(_decode(v) for v in value)
            if tag == "__bytes__":
                return base64.b64decode(value)
            if tag == "__dict__":
                return {_tuple_key(_decode(k)): _decode(v) for k, v in value}
        return {k: _decode(v) for k, v in obj.items()}
    return obj


def _tuple_key(key):
    return tuple(_tuple_key(v) for v in key) if isinstance(key, list) else key


def dumps_data(obj) -> str:
    """``obj`` (arrays, numbers, strings, lists, tuples, dicts, bytes, None) as JSON text that
    ``loads_data`` reads back equal, bit for bit (floats and arrays exactly, NaN and infinities
    included); ``TypeError`` for anything else."""
    return json.dumps(_encode(obj), allow_nan=True, separators=(",", ":"))


def loads_data(text: str):
    """The object ``dumps_data`` wrote as ``text`` (reading it runs no code); ``ValueError`` if it is
    not such a text."""
    try:
        return _decode(json.loads(text))
    except (TypeError, KeyError, IndexError) as e:
        raise ValueError(f"not a data file: {type(e).__name__}: {e}") from None


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def write_text(path: str | Path, text: str) -> None:
    """Write ``text`` to ``path`` atomically."""
    with atomic_path(path) as tmp:
        tmp.write_text(text)


def write_csv(path: str | Path, header: list[str], rows) -> None:
    """Write a CSV (a header row, then ``rows``) atomically."""
    buf = io.StringIO()
    w = csv.writer(buf)
    w.writerow(header)
    w.writerows(rows)
    write_text(path, buf.getvalue())


def json_safe(obj):
    """``obj`` with every NaN float as None (standard JSON has no NaN; here NaN marks "no value",
    e.g. a runaway drive's velocity), NumPy scalars as Python numbers, tuples and arrays as lists."""
    if isinstance(obj, dict):
        return {k: json_safe(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [json_safe(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return json_safe(obj.tolist())
    if isinstance(obj, np.generic):
        obj = obj.item()
    if isinstance(obj, float) and math.isnan(obj):
        return None
    return obj


def nan_array(values) -> np.ndarray:
    """A list of numbers read back from JSON as a float array, None as NaN (``json_safe``'s inverse)."""
    return np.array([np.nan if v is None else v for v in values], dtype=float)


def save_figure(fig, path: str | Path, dpi: int = 120) -> None:
    """Save a matplotlib figure atomically (the format follows the suffix of ``path``)."""
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=dpi, format=Path(path).suffix.lstrip(".") or "png")
