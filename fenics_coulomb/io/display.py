"""A private virtual X display (Xvfb) for the off-screen figures, owned by the process that needs it.

pyvista's ``start_xvfb`` starts ``Xvfb :99`` in the background through a shell and never stops it: every run
with plots left an Xvfb behind, and concurrent runs fought over display :99. :func:`virtual_display` instead
lets Xvfb pick a free display (``-displayfd``), ties its life to this process (``PR_SET_PDEATHSIG``, so it
dies even when this process is killed), and stops it when the block ends, also on an exception or interrupt.
"""

from __future__ import annotations

import contextlib
import ctypes
import logging
import os
import shutil
import signal
import subprocess
from collections.abc import Iterator

__all__ = ["virtual_display"]

logger = logging.getLogger(__name__)

_PR_SET_PDEATHSIG = 1


def _die_with_parent() -> None:  # runs in the child between fork and exec
    with contextlib.suppress(Exception):
        ctypes.CDLL(None, use_errno=True).prctl(_PR_SET_PDEATHSIG, signal.SIGKILL)


def _wait_for_display(display: str, timeout: float = 10.0) -> bool:
    """Wait until an X client can connect to ``display`` (Xvfb reports its number before it serves)."""
    import ctypes.util
    import time

    name = ctypes.util.find_library("X11")
    if name is None:
        return True
    xlib = ctypes.cdll.LoadLibrary(name)
    xlib.XOpenDisplay.restype = ctypes.c_void_p
    xlib.XOpenDisplay.argtypes = [ctypes.c_char_p]
    xlib.XCloseDisplay.argtypes = [ctypes.c_void_p]
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        connection = xlib.XOpenDisplay(display.encode())
        if connection:
            xlib.XCloseDisplay(connection)
            return True
        time.sleep(0.05)
    return False


@contextlib.contextmanager
def virtual_display(enabled: bool = True, timeout: float = 10.0) -> Iterator[str | None]:
    """Run the block with ``DISPLAY`` set to a private Xvfb, stopped when the block ends.

    Nothing is started when ``enabled`` is False, when a display is already set, or when Xvfb is not
    installed (VTK may still render off screen); the block then runs unchanged.

    Yields:
        The display name (e.g. ``":3"``) or None.
    """
    xvfb = shutil.which("Xvfb")
    if not enabled or os.environ.get("DISPLAY") or xvfb is None:
        yield None
        return
    read_fd, write_fd = os.pipe()
    try:
        proc = subprocess.Popen(
            [xvfb, "-displayfd", str(write_fd), "-screen", "0", "1280x1024x24", "-nolisten", "tcp",
             "-noreset"],  # without it the server resets when its first client disconnects (pvpython fails)
            pass_fds=(write_fd,), stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
            preexec_fn=_die_with_parent,
        )
    except OSError as err:
        os.close(read_fd)
        os.close(write_fd)
        logger.warning("Xvfb could not be started (%s); rendering without a display", err)
        yield None
        return
    os.close(write_fd)
    display = None
    try:
        import select

        number = b""
        ready, _, _ = select.select([read_fd], [], [], timeout)
        while ready:
            chunk = os.read(read_fd, 16)
            if not chunk:
                break
            number += chunk
            if number.endswith(b"\n"):
                break
            ready, _, _ = select.select([read_fd], [], [], timeout)
        if number.strip().isdigit() and _wait_for_display(f":{int(number)}", timeout):
            display = f":{int(number)}"
            os.environ["DISPLAY"] = display
        else:
            logger.warning("Xvfb did not report a display; rendering without one")
        yield display
    finally:
        os.close(read_fd)
        if display is not None and os.environ.get("DISPLAY") == display:
            del os.environ["DISPLAY"]
        proc.terminate()
        try:
            proc.wait(timeout=5)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
