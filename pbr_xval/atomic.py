"""Atomic file writes: a temporary file in the target's folder, fsync, then ``os.replace``.

A reader (or a resumed run) sees either the old file or the complete new one, never a
partial write. Used by trajectories, reports, the catalog store and the geometry cache.

Files get the mode a plain ``open()`` would give them (``0o666`` less the umask: 0644 under
umask 022), not the ``0600`` of :func:`tempfile.mkstemp`, so colleagues and web servers can
read reports and stores.

Temporary names carry the writer's host and process id (``<name>.pid<pid>@<host>.<random>.tmp``),
so a temporary left behind by a killed process is recognised as stale (its process is gone) and
removed by the next atomic write into the same folder (:func:`clean_stale_temporaries`; the report
writer also calls it for its ``<name>.tmp-<pid>/`` staging folders).
"""

from __future__ import annotations

import contextlib
import os
import re
import shutil
import socket
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path
from typing import IO, Any

__all__ = [
    "atomic_file",
    "check_output_dir",
    "check_output_file",
    "clean_stale_temporaries",
    "file_mode",
    "write_bytes_atomic",
    "write_figure_atomic",
    "write_parquet_atomic",
    "write_text_atomic",
]

#: a temporary file of :func:`atomic_file`: ``[.]<name>.pid<pid>@<host>.<random>.tmp``
_TMP_FILE = re.compile(r"\.pid(\d+)@([A-Za-z0-9_-]*)\.[A-Za-z0-9_]+\.tmp$")
#: a report staging folder of :mod:`pbr_xval.report.writer`: ``<name>.tmp-<pid>``
_TMP_DIR = re.compile(r"\.tmp-(\d+)$")
#: temporaries of older versions (``<name>.<8 random>.tmp``, no pid) count as stale after this, s
LEGACY_MAX_AGE = 24 * 3600.0
_LEGACY_TMP_FILE = re.compile(r"\.[A-Za-z0-9_]{8}\.tmp$")

_cleaned: set[Path] = set()


def _host() -> str:
    return re.sub(r"[^A-Za-z0-9_-]", "_", socket.gethostname())[:40]


def _umask() -> int:
    """The process umask, read without changing it (``/proc``) where possible."""
    try:
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    old = os.umask(0o022)  # not thread-safe, hence the /proc route first
    os.umask(old)
    return old


def file_mode() -> int:
    """Mode of a newly created file: ``0o666`` less the umask (0644 under umask 022)."""
    return 0o666 & ~_umask()


def _pid_alive(pid: int) -> bool:
    if pid <= 0:
        return True  # not a real pid: leave the file alone
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # someone else's live process
        return True
    except OSError:
        return True
    return True


def clean_stale_temporaries(folder: str | os.PathLike[str], *, recursive: bool = False) -> list[Path]:
    """Remove temporaries in ``folder`` left behind by writers that died; return what was removed.

    ``recursive``: also in every sub-folder (a catalog store's ``engine=*/rock=*/`` tree).

    Removed: :func:`atomic_file` temporaries written on this host by a process that no longer
    exists; report staging folders ``<name>.tmp-<pid>`` whose process no longer exists; and
    temporaries of older versions (no pid in the name) untouched for :data:`LEGACY_MAX_AGE`.
    A temporary of a live process, or of another host (a shared file system), is never touched.
    """
    folder = Path(folder)
    removed: list[Path] = []
    host = _host()
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return removed
    for e in entries:
        name = e.name
        try:
            if e.is_file(follow_symlinks=False) and name.endswith(".tmp"):
                m = _TMP_FILE.search(name)
                if m:
                    stale = m.group(2) == host and not _pid_alive(int(m.group(1)))
                else:
                    stale = (
                        _LEGACY_TMP_FILE.search(name) is not None
                        and time.time() - e.stat(follow_symlinks=False).st_mtime > LEGACY_MAX_AGE
                    )
                if stale:
                    Path(e.path).unlink(missing_ok=True)
                    removed.append(Path(e.path))
            elif e.is_dir(follow_symlinks=False):
                m = _TMP_DIR.search(name)
                if m and not _pid_alive(int(m.group(1))):
                    shutil.rmtree(e.path, ignore_errors=True)
                    removed.append(Path(e.path))
                elif recursive:
                    removed += clean_stale_temporaries(e.path, recursive=True)
        except OSError:  # raced with another cleaner or the writer itself
            continue
    return removed


def _clean_once(folder: Path) -> None:
    key = folder.resolve()
    if key not in _cleaned:
        _cleaned.add(key)
        clean_stale_temporaries(folder)


@contextlib.contextmanager
def atomic_file(path: str | os.PathLike[str], mode: str = "wb", *, hidden: bool = False) -> Iterator[IO[Any]]:
    """Open a temporary file beside ``path``; on success it replaces ``path``, on error it is removed.

    ``hidden`` starts the temporary name with a dot (readers that skip dot files, like the
    catalog store's Parquet dataset, never see it). The first write into a folder (per process)
    also removes stale temporaries there (:func:`clean_stale_temporaries`).
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    _clean_once(path.parent)
    fd, tmp = tempfile.mkstemp(
        prefix=("." if hidden else "") + f"{path.name}.pid{os.getpid()}@{_host()}.",
        suffix=".tmp",
        dir=path.parent,
    )
    try:
        with os.fdopen(fd, mode) as fh:
            yield fh
            fh.flush()
            os.fchmod(fh.fileno(), file_mode())
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def write_bytes_atomic(path: str | os.PathLike[str], data: bytes, *, hidden: bool = False) -> Path:
    with atomic_file(path, "wb", hidden=hidden) as fh:
        fh.write(data)
    return Path(path)


def write_text_atomic(path: str | os.PathLike[str], text: str, *, hidden: bool = False) -> Path:
    return write_bytes_atomic(path, text.encode("utf-8"), hidden=hidden)


def write_figure_atomic(path: str | os.PathLike[str], fig: Any, **savefig_kw: Any) -> Path:
    """Save a matplotlib figure atomically (format from the suffix unless ``format`` is given)."""
    import io

    path = Path(path)
    buf = io.BytesIO()
    savefig_kw.setdefault("format", path.suffix.lstrip(".").lower() or "png")
    fig.savefig(buf, **savefig_kw)
    return write_bytes_atomic(path, buf.getvalue())


def write_parquet_atomic(path: str | os.PathLike[str], table: Any, *, hidden: bool = False) -> Path:
    """Write a pyarrow Table as Parquet, atomically."""
    import pyarrow.parquet as pq

    with atomic_file(path, "wb", hidden=hidden) as fh:
        pq.write_table(table, fh)
    return Path(path)


# ------------------------------------------------------------------ output locations, checked up front
def _writable_ancestor(path: Path, label: str) -> None:
    """The nearest existing ancestor of ``path`` must be a folder in which a file can be created."""
    from pbr_xval.errors import OutputPathError

    for parent in path.parents:
        if parent.exists():
            if not parent.is_dir():
                raise OutputPathError(f"{label}: {parent} is a file; expected a folder")
            break
    else:  # pragma: no cover - the root always exists
        parent = Path(path.anchor or ".")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise OutputPathError(
            f"{label}: {parent} is not writable (permission denied); expected a writable location"
        )
    try:  # a real probe: read-only mounts, /sys, ACLs (os.access says yes to root)
        fd, probe = tempfile.mkstemp(
            prefix=f".write-probe.pid{os.getpid()}@{_host()}.", suffix=".tmp", dir=parent
        )
    except OSError as exc:
        why = exc.strerror or type(exc).__name__
        raise OutputPathError(
            f"{label}: cannot create files in {parent} ({why.lower()}); expected a writable location"
        ) from None
    os.close(fd)
    Path(probe).unlink(missing_ok=True)


def check_output_dir(path: str | os.PathLike[str], option: str) -> Path:
    """Check, before any work, that the folder ``path`` can be written (existing or to be created).

    Refused (:class:`~pbr_xval.errors.OutputPathError`, one line naming ``option``): an existing
    file at ``path`` or at any of its ancestors, and a location where no file can be created
    (read-only folder or file system). Nothing is created. Returns ``Path(path)``.
    """
    from pbr_xval.errors import OutputPathError

    p = Path(path)
    label = f"{option} {path}"
    if p.exists() and not p.is_dir():
        raise OutputPathError(f"{label}: is a file; expected a folder (a new one or an existing one)")
    if p.is_dir():
        _writable_ancestor(p / "x", label)
    else:
        _writable_ancestor(p, label)
    return p


def check_output_file(
    path: str | os.PathLike[str],
    option: str,
    *,
    overwrite: bool = True,
    default_name: str | None = None,
) -> Path:
    """Check, before any work, that the file ``path`` can be written; return the file's path.

    ``path`` naming a folder — an existing one, or any path written with a trailing slash
    (``--out newdir/``) — means ``path/default_name`` when ``default_name`` is given, else it is
    refused. Refused (:class:`~pbr_xval.errors.OutputPathError`, one line naming ``option``): a
    folder where the file should be, an existing file unless ``overwrite`` (the message names
    ``--overwrite``), an ancestor that is a file, and a location where no file can be created.
    Nothing is created.
    """
    from pbr_xval.errors import OutputPathError

    raw = os.fspath(path)
    p = Path(raw)
    label = f"{option} {raw}"
    as_dir = raw.endswith(("/", os.sep)) or p.is_dir()
    if as_dir:
        if p.exists() and not p.is_dir():
            raise OutputPathError(f"{label}: is a file; expected a folder (the path ends with a slash)")
        if default_name is None:
            raise OutputPathError(f"{label}: is a folder; expected a file path")
        p = p / default_name
        label = f"{option} {p}"
        if p.is_dir():
            raise OutputPathError(f"{label}: is a folder; expected a file path")
    elif p.is_dir():  # pragma: no cover - covered by as_dir
        raise OutputPathError(f"{label}: is a folder; expected a file path")
    if p.exists() and not overwrite:
        raise OutputPathError(f"{label}: file exists; pass --overwrite to replace it, or choose another path")
    _writable_ancestor(p, label)
    return p
