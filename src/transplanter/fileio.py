"""Files at the edges: inputs read only from regular files of bounded size, outputs written
atomically through exclusive temporary files that never follow a link.

Outputs: `check_output(path)` is called before any work starts (it proves the directory
writable by creating and removing a temporary file there and returns the file that will
really be written: a symlink's target). `temp_beside(target)` creates the temporary file
exclusively (`tempfile.mkstemp`: unpredictable name, O_EXCL) in the target's directory and
`commit(tmp, target)` moves it into place, keeping an existing file's mode. A failure leaves
the old file as it was and no temporary file behind.

Links: a name the user gave (`--json r.json`) that is a symlink is written through to its
target (the user's choice). A name the program derives (`NAME.partial.rrd`, a sweep's
`runs.csv`, `assets/*.stl`) never is: `check_output(path, derived=True)` refuses a link
there, and `commit(..., follow=False)` replaces a link planted later by the file itself.
`same_file(a, b)` says whether two paths are one file (links resolved, hard links by inode),
so that no output replaces an input or another output.
"""

from __future__ import annotations

import json
import os
import stat
import tempfile
from pathlib import Path
from typing import Any

from transplanter.errors import TransplanterError

__all__ = [
    "FileRefused",
    "check_output",
    "commit",
    "discard",
    "read_text_input",
    "same_file",
    "temp_beside",
    "write_json_atomic",
]


class FileRefused(TransplanterError, ValueError):
    """An input or output path that cannot be used; the message says why and what to do."""


def _kind(mode: int) -> str:
    for test, name in (
        (stat.S_ISDIR, "a directory"),
        (stat.S_ISFIFO, "a named pipe (FIFO)"),
        (stat.S_ISCHR, "a character device"),
        (stat.S_ISBLK, "a block device"),
        (stat.S_ISSOCK, "a socket"),
    ):
        if test(mode):
            return name
    return "not a regular file"


def read_text_input(path: str | os.PathLike, max_bytes: int, what: str) -> str:
    """The UTF-8 text of a regular file of at most max_bytes; FileRefused otherwise (a FIFO,
    a device such as /dev/zero, a directory, a missing or oversized file)."""
    path = Path(path)
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK)  # a FIFO must not block the open
    except FileNotFoundError:
        raise FileRefused(f"{path}: no such {what} file.") from None
    except OSError as exc:
        raise FileRefused(f"{path}: cannot read the {what} file: {exc.strerror}.") from None
    st = os.fstat(fd)
    if not stat.S_ISREG(st.st_mode):
        os.close(fd)
        raise FileRefused(f"{path} is {_kind(st.st_mode)}; give a {what} file.")
    with os.fdopen(fd, "rb") as f:
        if st.st_size > max_bytes:
            raise FileRefused(
                f"{path} is {st.st_size} bytes; a {what} file is at most {max_bytes} bytes."
            )
        data = f.read(max_bytes + 1)
    if len(data) > max_bytes:
        raise FileRefused(f"{path} grew past {max_bytes} bytes while being read.")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:
        raise FileRefused(f"{path}: not a text file (UTF-8 expected for a {what}).") from None


def same_file(a: str | os.PathLike, b: str | os.PathLike) -> bool:
    """Whether paths a and b name one file: the same path once links and '..' are resolved,
    or (both existing) the same inode, as a hard link is."""
    if os.path.realpath(a) == os.path.realpath(b):
        return True
    try:
        return os.path.samefile(a, b)
    except OSError:  # one of them does not exist (yet)
        return False


def check_output(
    path: str | os.PathLike, suffix: str | None = None, *, derived: bool = False
) -> Path:
    """The file that writing `path` will replace (a symlink's target), after proving that it
    can be written there; FileRefused with the reason otherwise. Call it before any work.
    `derived`: a name the program made up, where a symlink is refused, never followed."""
    path = Path(path)
    if suffix is not None and path.suffix != suffix:
        raise FileRefused(f"{path} must end in {suffix}")
    if derived and path.is_symlink():
        raise FileRefused(
            f"{path} is a symbolic link; the program writes this name itself and never "
            "through a link: remove the link"
        )
    target = Path(os.path.realpath(path)) if path.is_symlink() else path
    try:
        st = target.stat()
    except FileNotFoundError:
        st = None
    except OSError as exc:
        raise FileRefused(f"{target}: {exc.strerror}") from None
    if st is not None and not stat.S_ISREG(st.st_mode):
        kind = _kind(st.st_mode)
        hint = "give a file name" if stat.S_ISDIR(st.st_mode) else "give a regular file's path"
        raise FileRefused(f"{path} is {kind}; {hint}")
    if not target.parent.is_dir():
        raise FileRefused(f"{target.parent} does not exist; create it first")
    try:
        discard(temp_beside(target))
    except OSError as exc:
        raise FileRefused(f"{target.parent} is not writable: {exc.strerror}") from None
    return target


def temp_beside(target: Path) -> Path:
    """A new, empty temporary file in target's directory, created exclusively."""
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
    os.close(fd)
    return Path(tmp)


def discard(tmp: Path) -> None:
    Path(tmp).unlink(missing_ok=True)


def commit(tmp: Path, target: Path, *, follow: bool = True) -> None:
    """Move a finished temporary file onto target: synced, with the mode target had (a new
    file: readable by others as the umask allows), atomically replacing it. A symlink at
    target is written through to its target (`follow`, a name the user gave) or replaced
    itself (`follow=False`, a name the program derived)."""
    target = Path(target)
    if follow and target.is_symlink():
        target = Path(os.path.realpath(target))
    try:
        st = target.stat() if follow else target.lstat()
    except FileNotFoundError:
        st = None
    if st is not None and stat.S_ISREG(st.st_mode):
        mode = stat.S_IMODE(st.st_mode)
    else:
        umask = os.umask(0)
        os.umask(umask)
        mode = 0o666 & ~umask  # mkstemp makes files private; results are for sharing
    try:
        with open(tmp, "rb") as f:
            os.fsync(f.fileno())
        os.chmod(tmp, mode)
        os.replace(tmp, target)
    except BaseException:
        discard(tmp)
        raise


def write_text_atomic(path: str | os.PathLike, text: str, *, follow: bool = True) -> None:
    """Write text so that the file is either the old one or the complete new one (through a
    symlink: its target, with the temporary file beside the target; with `follow=False`
    the link itself is replaced)."""
    path = Path(path)
    target = Path(os.path.realpath(path)) if follow and path.is_symlink() else path
    tmp = temp_beside(target)
    try:
        tmp.write_text(text, encoding="utf-8")
    except BaseException:
        discard(tmp)
        raise
    commit(tmp, target, follow=follow)


def write_json_atomic(
    path: str | os.PathLike, payload: dict[str, Any], *, follow: bool = True
) -> None:
    """Write JSON so that the file is either the old one or the complete new one."""
    write_text_atomic(path, json.dumps(payload, indent=2, sort_keys=True) + "\n", follow=follow)
