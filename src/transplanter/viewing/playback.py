"""Play back and read recordings: open an .rrd in the rerun viewer, summarise what it holds.

The entity layout is the one `transplanter.viewing.recording` writes (see its docstring).
"""

from __future__ import annotations

import math
import os
import shutil
import stat
import subprocess
import sys
import warnings
from collections import Counter
from pathlib import Path

import rerun as rr

from transplanter import fileio
from transplanter.viewing.recording import EVENTS_ENTITY, SCALARS_ROOT, TIMELINE

__all__ = ["replay", "read_summary"]


def _has_display() -> bool:
    if not sys.platform.startswith("linux"):
        return True
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


RRD_MAGIC = b"RRF2"
"""The first bytes of a rerun 0.41 recording file (its file header's magic)."""


def _check_rrd(path: str | os.PathLike) -> Path:
    """The recording's path once it is a regular file that starts as an .rrd does:
    FileNotFoundError when nothing is there, ValueError naming what is there instead (a
    directory, a FIFO: opened without blocking and never read) or why it is no recording."""
    rrd = Path(path)
    try:
        fd = os.open(rrd, os.O_RDONLY | os.O_NONBLOCK)  # a FIFO must not block the open
    except FileNotFoundError:
        raise FileNotFoundError(f"recording {str(rrd)!r} does not exist") from None
    except OSError as error:
        raise ValueError(f"recording {str(rrd)!r} cannot be read: {error.strerror}") from None
    try:
        mode = os.fstat(fd).st_mode
        if not stat.S_ISREG(mode):
            raise ValueError(
                f"{str(rrd)!r} is {fileio._kind(mode)}, not a recording: give a recording "
                "file (.rrd, as `transplanter trial --record` writes)"
            )
        if rrd.suffix != ".rrd":
            raise ValueError(f"{str(rrd)!r} is not a rerun recording: expected a .rrd file")
        head = os.read(fd, len(RRD_MAGIC))
    except OSError as error:  # EISDIR and the like, should the file change under us
        raise ValueError(f"recording {str(rrd)!r} cannot be read: {error.strerror}") from None
    finally:
        os.close(fd)
    if head != RRD_MAGIC:
        raise ValueError(
            f"{str(rrd)!r} is not a rerun recording: it does not start as an .rrd file does "
            f"({RRD_MAGIC!r}); was it written by `transplanter trial --record`?"
        )
    return rrd


def _rerun_command() -> list[str]:
    beside_python = Path(sys.executable).with_name("rerun")
    if beside_python.is_file():
        return [str(beside_python)]
    on_path = shutil.which("rerun")
    return [on_path] if on_path else [sys.executable, "-m", "rerun"]


def replay(path: str | os.PathLike, wait: bool = True) -> int:
    """Open a recording in the rerun viewer.

    Returns 0 when the viewer ran, 1 for a missing or non-.rrd file (or a viewer that could
    not start), 2 when there is no display to open a window on (it then prints how to view
    the file elsewhere). With ``wait`` False it returns as soon as the viewer started.
    """
    try:
        rrd = _check_rrd(path)
    except (FileNotFoundError, ValueError) as error:
        print(f"replay: {error}", file=sys.stderr)
        return 1
    if not _has_display():
        print(
            f"replay: no display (DISPLAY and WAYLAND_DISPLAY are unset), so no viewer window "
            f"can open here. To watch {str(rrd)!r}:\n"
            f"  - copy it to a machine with a display and run: rerun {rrd.name}\n"
            f"  - or serve it to a browser from here: rerun --serve-web {rrd}\n"
            f"    then open the printed http://...:9090 address (forward port 9090 and the "
            f"gRPC port 9876 over ssh if needed)",
            file=sys.stderr,
        )
        return 2
    command = [*_rerun_command(), str(rrd)]
    try:
        viewer = subprocess.Popen(command)
    except OSError as error:
        print(f"replay: could not start the rerun viewer ({command[0]}): {error}", file=sys.stderr)
        return 1
    if not wait:
        return 0
    return 0 if viewer.wait() == 0 else 1


def _strip_root(entity_path: str) -> str:
    return entity_path.lstrip("/")


def read_summary(path: str | os.PathLike) -> dict:
    """What an .rrd holds, read back with rerun's own reader.

    Keys: ``application_id``; ``entity_paths`` (sorted, without the leading '/', rerun's
    internal ``__properties`` left out); ``static_components`` and ``temporal_components``
    (entity -> sorted component names such as 'Transform3D:translation');
    ``rows_on_sim_time`` (entity -> number of rows on the sim_time timeline);
    ``sim_time_range`` ((min, max) seconds, or None); ``scalar_channels`` (names below
    'scalars/'); ``events`` (kind -> count); ``has_blueprint``; ``blueprint_views``
    ((view class, origin) pairs such as ('TimeSeries', 'scalars/motors')).
    """
    rrd = _check_rrd(path)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # rerun warns before it fails on a cut-off file
            reader = rr.chunk.RrdReader(rrd)
            recordings = reader.recordings()
            store = reader.store() if recordings else None
    except RuntimeError as error:
        raise ValueError(f"{str(rrd)!r} is not a complete rerun recording: {error}") from error
    if store is None:
        raise ValueError(f"{str(rrd)!r} holds no recording")

    static_components: dict[str, set[str]] = {}
    temporal_components: dict[str, set[str]] = {}
    for column in store.schema().component_columns():
        entity = _strip_root(str(column.entity_path))
        if entity.startswith("__"):
            continue
        target = static_components if column.is_static else temporal_components
        target.setdefault(entity, set()).add(column.component)

    rows_on_sim_time: Counter[str] = Counter()
    t_min, t_max = math.inf, -math.inf
    event_kinds: Counter[str] = Counter()
    for chunk in store.stream().filter(has_timeline=TIMELINE):
        entity = _strip_root(chunk.entity_path)
        batch = chunk.to_record_batch()
        rows_on_sim_time[entity] += chunk.num_rows
        times_ns = batch.column(TIMELINE).cast("int64").to_numpy()
        if times_ns.size:
            t_min = min(t_min, times_ns.min() * 1e-9)
            t_max = max(t_max, times_ns.max() * 1e-9)
        if entity == EVENTS_ENTITY:
            event_kinds.update(_event_kinds(batch))

    entities = set(static_components) | set(temporal_components)
    return {
        "application_id": recordings[0].application_id,
        "entity_paths": sorted(entities),
        "static_components": {e: sorted(c) for e, c in sorted(static_components.items())},
        "temporal_components": {e: sorted(c) for e, c in sorted(temporal_components.items())},
        "rows_on_sim_time": dict(sorted(rows_on_sim_time.items())),
        "sim_time_range": None if t_min > t_max else (float(t_min), float(t_max)),
        "scalar_channels": sorted(
            e[len(SCALARS_ROOT) + 1 :]
            for e in temporal_components
            if e.startswith(SCALARS_ROOT + "/")
        ),
        "events": dict(sorted(event_kinds.items())),
        "has_blueprint": bool(reader.blueprints()),
        "blueprint_views": _blueprint_views(reader),
    }


def _blueprint_views(reader) -> list[tuple[str, str]]:
    """(view class, origin) of every view in the file's first blueprint, sorted."""
    blueprints = reader.blueprints()
    if not blueprints:
        return []
    views = []
    for chunk in reader.store(store=blueprints[0]).stream():
        batch = chunk.to_record_batch()
        names = batch.schema.names
        if "ViewBlueprint:class_identifier" in names and "ViewBlueprint:space_origin" in names:
            kinds = batch.column("ViewBlueprint:class_identifier").to_pylist()
            origins = batch.column("ViewBlueprint:space_origin").to_pylist()
            views += [(_first(k), _first(o)) for k, o in zip(kinds, origins, strict=True)]
    return sorted(views)


def _event_kinds(batch) -> list[str]:
    """Kinds of the events in a record batch of the ``events`` entity."""
    names = batch.schema.names
    kind_columns = [n for n in names if n.split(":")[-1] == "kind"]
    if kind_columns:
        column = batch.column(kind_columns[0]).to_pylist()
        return [_first(value) for value in column if value is not None]
    # Files written by other tools: kinds are the 'kind: text' prefix of the log lines.
    text_column = batch.column("TextLog:text").to_pylist() if "TextLog:text" in names else []
    return [_first(value).split(":")[0] for value in text_column if value is not None]


def _first(value):
    return value[0] if isinstance(value, list) else value
