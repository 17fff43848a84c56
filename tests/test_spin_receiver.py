"""The lockstep link's receive: spin on non-blocking reads, then wait in poll with the timeout asked for;
the socket itself stays blocking (so sendall on it blocks as usual)."""

from __future__ import annotations

import socket
import threading

import pytest

from mavsim_core.spin_receiver import SHORT_SPIN_S, SPIN_BUDGET_S, SPIN_ENV, SpinReceiver, spin_budget_from_env


def test_recv_times_out_then_waits_until_data_and_leaves_the_socket_blocking():
    a, b = socket.socketpair()
    with a, b:
        a.settimeout(2.0)  # a timeout set by someone else: the receiver makes the socket blocking again
        rx = SpinReceiver(a)
        with pytest.raises(socket.timeout):
            rx.recv(64, timeout_s=0.05)
        assert a.gettimeout() is None
        b.sendall(b"x")
        assert rx.recv(64, timeout_s=0.05) == b"x"  # data waiting: at once
        timer = threading.Timer(0.3, b.sendall, (b"late",))  # arrives after the spin: the wait gets it
        timer.start()
        try:
            assert rx.recv(64, timeout_s=None) == b"late"
        finally:
            timer.cancel()
        with pytest.raises(socket.timeout):
            rx.recv(64, timeout_s=0.0)  # nothing there: a zero timeout answers at once
        assert a.gettimeout() is None


def test_a_closed_peer_reads_as_end_of_stream():
    a, b = socket.socketpair()
    with a:
        rx = SpinReceiver(a)
        b.close()
        assert rx.recv(64, timeout_s=1.0) == b""


def test_the_spin_shortens_while_it_keeps_missing_and_lengthens_when_it_catches_again():
    a, b = socket.socketpair()
    with a, b:
        rx = SpinReceiver(a, SPIN_BUDGET_S)  # explicit: the suite's own environment turns the spin off
        assert rx.spin_budget_s == SPIN_BUDGET_S
        for _ in range(10):  # the peer answers only after the spin: each spin missed
            with pytest.raises(socket.timeout):
                rx.recv(64, timeout_s=0.001)
        assert rx.spin_budget_s == SHORT_SPIN_S
        for _ in range(40):  # the data is there each time: caught while spinning
            b.sendall(b"x")
            assert rx.recv(64, timeout_s=1.0) == b"x"
        assert rx.spin_budget_s == SPIN_BUDGET_S


def test_the_environment_sets_the_budget_and_zero_never_spins(monkeypatch):
    assert spin_budget_from_env({}) == SPIN_BUDGET_S
    assert spin_budget_from_env({SPIN_ENV: "150"}) == pytest.approx(150e-6)
    assert spin_budget_from_env({SPIN_ENV: "0"}) == 0.0
    for bad in ("fast", "-5", "nan"):
        with pytest.raises(ValueError, match=SPIN_ENV):
            spin_budget_from_env({SPIN_ENV: bad})
    monkeypatch.setenv(SPIN_ENV, "0")
    a, b = socket.socketpair()
    with a, b:
        rx = SpinReceiver(a)  # from the environment
        assert rx.spin_budget_s == 0.0
        b.sendall(b"x")
        assert rx.recv(64, timeout_s=1.0) == b"x"  # data waiting: read at once, without a spin
        with pytest.raises(socket.timeout):
            rx.recv(64, timeout_s=0.01)
        assert rx.spin_budget_s == 0.0  # still none after a miss (not the short spin)
