"""A child that ends with its parent (Linux): the one place the stack, its fork server and a campaign's pool
workers ask the kernel for a SIGTERM when the process that started them goes, even by SIGKILL."""

from __future__ import annotations

import ctypes
import signal

PR_SET_PDEATHSIG = 1


def die_with_parent() -> None:
    """Ask for SIGTERM when the parent ends (``prctl(PR_SET_PDEATHSIG)``; nothing where there is no prctl).

    Linux sends it when the *thread* that started this process exits, so a process started from a short-lived
    thread gets it when that thread ends (the fork server watches its parent process instead)."""
    try:
        ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, signal.SIGTERM)
    except (OSError, AttributeError):
        pass
