"""Ctrl-C and SIGTERM, one way: a request to stop that never costs work already finished.

SIGTERM is what a scheduler, `timeout` or a container stop sends; it asks what Ctrl-C asks.
`handling()` (the command line, around one command) makes both raise KeyboardInterrupt in the
main thread (`Terminated`, a KeyboardInterrupt, for SIGTERM), so that every place that stops
cleanly on Ctrl-C stops the same way on SIGTERM; a signal the process was started with
ignored (`nohup`, a background job's SIGINT) stays ignored.

`held()` marks code that must not be cut in the middle: setting up a trial's files, its end
(the judge's last verdicts, closing the recording) and writing results. A stop signal that
arrives inside is held, not raised there: it stays `pending()` until the code outside acts
on it: `raise_pending()` raises it (where stopping is clean again: the start of a trial's
loop), `take_pending()` reads and clears it (the command line's exit status). A second
signal while one is held raises at once: pressing Ctrl-C twice is the way out of a hang.
Outside `handling()` (a library call, a notebook), `held()` holds Python's own Ctrl-C the
same way; it never touches a handler someone else set (a pool worker's SIG_IGN).
"""

from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Iterator

__all__ = [
    "STOP_SIGNALS",
    "Terminated",
    "commanded",
    "handling",
    "held",
    "pending",
    "raise_pending",
    "received",
    "take_pending",
]

STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised where Ctrl-C raises KeyboardInterrupt."""

    def __init__(self) -> None:
        super().__init__("terminated (SIGTERM)")


class _State:
    def __init__(self) -> None:
        self.depth = 0  # held() blocks entered and not left
        self.pending: int | None = None  # a signal held, not yet acted on
        self.received: int | None = None  # the last stop signal of this command
        self.commanded = False  # handling() is active


_state = _State()


def _stop(signum: int) -> KeyboardInterrupt:
    return Terminated() if signum == signal.SIGTERM else KeyboardInterrupt()


def _handler(signum: int, frame) -> None:
    _state.received = signum
    if _state.depth and _state.pending is None:
        _state.pending = signum  # acted on once the held code is done
        return
    _state.pending = None  # raised now: acted on
    raise _stop(signum)


def _in_main_thread() -> bool:
    return threading.current_thread() is threading.main_thread()


@contextlib.contextmanager
def handling() -> Iterator[None]:
    """SIGINT and SIGTERM raise KeyboardInterrupt (Terminated) in the main thread inside,
    are held inside `held()`, and the handlers before are restored after. Elsewhere than in
    the main thread: nothing changes."""
    if not _in_main_thread():
        yield
        return
    previous = {s: signal.getsignal(s) for s in STOP_SIGNALS}
    _state.pending = _state.received = None
    _state.commanded = True
    try:
        for s, handler in previous.items():
            if handler is not signal.SIG_IGN:
                signal.signal(s, _handler)
        yield
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)
        _state.commanded = False
        _state.pending = None


@contextlib.contextmanager
def held() -> Iterator[None]:
    """A stop signal arriving inside is not raised inside: it stays pending (see above)."""
    installed = None
    if _in_main_thread() and not _state.commanded and _state.depth == 0:
        if signal.getsignal(signal.SIGINT) is signal.default_int_handler:
            installed = signal.signal(signal.SIGINT, _handler)
    _state.depth += 1
    try:
        yield
    finally:
        _state.depth -= 1
        if installed is not None:
            signal.signal(signal.SIGINT, installed)


def pending() -> int | None:
    """The stop signal held and not yet acted on, if any."""
    return _state.pending


def take_pending() -> int | None:
    """The stop signal held and not yet acted on (now acted on), if any."""
    signum, _state.pending = _state.pending, None
    return signum


def raise_pending() -> None:
    """Raise the stop signal held, if any (KeyboardInterrupt, Terminated for SIGTERM)."""
    signum = take_pending()
    if signum is not None:
        raise _stop(signum)


def received() -> int | None:
    """The last stop signal received while `handling()` (held or raised), if any."""
    return _state.received


def commanded() -> bool:
    """Whether the command line handles the stop signals (`handling()` is active)."""
    return _state.commanded
