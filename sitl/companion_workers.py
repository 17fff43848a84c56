"""Where the vision companion's frames are rendered and read: a thread of the simulator, or a process of its own.

The lockstep loop (:class:`sitl.companion.LockstepCompanion`) hands a worker each capture, in capture order, and
takes the answers back in the same order at their release times.  Both workers run the same pipeline
(``LockstepCompanion.open_pipeline`` and ``process_frame``) on the same state, so they give the same frames and
the same messages for a seed (``SIM_CAM_PROC`` chooses; ``tests/test_companion_workers.py`` compares them):

* :class:`ThreadWorker` (``SIM_CAM_PROC`` 0): a thread of the simulator, working on a copy of the whole
  ``MjData``.  It shares the interpreter with the lockstep loop: the frame's Python parts (the fast renderer's
  numpy, the detector's glue) hold the lock the loop waits for at every step.
* :class:`ProcessWorker` (``SIM_CAM_PROC`` 1): a child process (``python -m sitl.companion_workers``, a fresh
  interpreter: a fork would inherit the GL driver's and OpenCV's threads mid-use) started when the companion is
  built and given the companion's constructor arguments (the model pickled, 3.5 MB in 17 ms).  Each capture sends
  it the state a frame is drawn from (:data:`STATE_FIELDS` of ``MjData``: positions and the poses MuJoCo computed
  from them, a few kB) over a socket pair; it answers with the packed LANDING_TARGET, the frame's record and,
  when the video or a photo wants the frame, its RGB image and detection, which the loop hands to the camera's
  media at the release.  The child runs in a session of its own (a stack's SIGTERM to the simulator's process
  group leaves it to answer the simulator's close with its statistics) and ends when the socket closes.

A worker holds at most ``IN_FLIGHT`` captures; a capture beyond that is dropped (which depends on simulated
times only).  Frames: MuJoCo's world (ENU); times in simulated microseconds.
"""

from __future__ import annotations

import os
import queue
import signal
import socket
import subprocess
import sys
import threading
from collections import deque
from dataclasses import dataclass
from multiprocessing.connection import Connection
from typing import TYPE_CHECKING, Callable

import mujoco
import numpy as np

if TYPE_CHECKING:
    from sitl.companion import CompanionStats, LockstepCompanion
    from sitl.truth_log import CameraFrame
    from vision.detector import MarkerDetection

IN_FLIGHT = 3  # captures that may wait for their release at once (latency / period + 1)
# The MjData arrays a frame is drawn and read from: the joints' positions, the bodies', geoms', sites', cameras' and
# lights' poses (MuJoCo's kinematics of the step, as the state was when captured) and the time.
STATE_FIELDS = (
    "qpos", "xpos", "xquat", "xmat", "xipos", "ximat", "geom_xpos", "geom_xmat", "site_xpos", "site_xmat",
    "cam_xpos", "cam_xmat", "light_xpos", "light_xdir", "subtree_com",
)  # fmt: skip


@dataclass
class FrameAnswer:
    """What a worker gives back for one capture: the packed LANDING_TARGET (b"": none), the frame's record, and the
    RGB frame with its detection when the media wanted it (None otherwise)."""

    packed: bytes
    frame: CameraFrame
    media: tuple[np.ndarray, MarkerDetection | None] | None = None


class StateCopy:
    """Packs :data:`STATE_FIELDS` of an ``MjData`` into one float64 vector and unpacks it into another."""

    def __init__(self, model: mujoco.MjModel) -> None:
        probe = mujoco.MjData(model)
        self.shapes = [(f, getattr(probe, f).shape) for f in STATE_FIELDS]
        self.size = 1 + sum(int(np.prod(s)) for _, s in self.shapes)
        self._views: tuple[mujoco.MjData, list[np.ndarray]] | None = None  # (the data packed last, its fields' views)

    def pack(self, data: mujoco.MjData) -> np.ndarray:
        """The state vector of ``data`` (the fields' flat views are kept for the next call with the same data: the
        simulator packs its one ``MjData`` 20 times a simulated second)."""
        if self._views is None or self._views[0] is not data:
            fields = [getattr(data, f) for f, _ in self.shapes]
            if not all(a.flags.c_contiguous for a in fields):  # (MuJoCo's are: a flat view is then the field itself)
                return np.concatenate(([data.time], *(a.ravel() for a in fields)))
            self._views = (data, [a.reshape(-1) for a in fields])
        return np.concatenate(([data.time], *self._views[1]))

    def unpack(self, state: np.ndarray, data: mujoco.MjData) -> None:
        data.time, at = float(state[0]), 1
        for f, shape in self.shapes:
            n = int(np.prod(shape))
            getattr(data, f)[...] = state[at : at + n].reshape(shape)
            at += n


class ThreadWorker:
    """The frames on a thread of the simulator, each from a copy of the whole ``MjData`` (module docstring)."""

    def __init__(self, companion: LockstepCompanion) -> None:
        self.c = companion
        self._free: deque[mujoco.MjData] = deque(mujoco.MjData(companion.model) for _ in range(IN_FLIGHT))
        self._answers: deque[queue.Queue] = deque()
        self._jobs: queue.Queue = queue.Queue()
        self._thread = threading.Thread(target=self._work, name="vision-companion", daemon=True)
        self._thread.start()

    def submit(self, data: mujoco.MjData, time_us: int, noise: float, want_media: bool) -> bool:
        """Start a frame from ``data`` captured at ``time_us``; False (dropped) when IN_FLIGHT already wait."""
        if not self._free:
            return False
        copy = self._free.popleft()
        mujoco.mj_copyData(copy, self.c.model, data)
        answer: queue.Queue = queue.Queue(maxsize=1)
        self._answers.append(answer)
        self._jobs.put((time_us, copy, noise, want_media, answer))
        return True

    def answer(self, keepalive: Callable[[], None] | None, every_s: float) -> FrameAnswer:
        """The oldest capture's answer, waited for (``keepalive`` called every ``every_s`` wall seconds meanwhile)."""
        answer = self._answers.popleft()
        while True:
            try:
                result = answer.get(timeout=every_s)
                break
            except queue.Empty:
                if keepalive is not None:
                    keepalive()
        if isinstance(result, BaseException):
            raise RuntimeError("vision companion failed") from result
        copy, out = result
        self._free.append(copy)
        return out

    def close(self) -> CompanionStats | None:
        """Stop the thread; the statistics were kept in the companion itself (None: nothing to add)."""
        self._jobs.put(None)
        self._thread.join(timeout=5.0)
        return None

    def _work(self) -> None:
        """Owns the renderer (its GL context belongs to this thread) and the detector."""
        try:
            pipeline = self.c.open_pipeline()
            error = None
        except BaseException as exc:  # reported to the main thread at the first release
            pipeline, error = None, exc
        while (job := self._jobs.get()) is not None:
            time_us, copy, noise, want_media, answer = job
            if pipeline is None:
                answer.put(error)
                continue
            try:
                out = self.c.process_frame(pipeline, copy, time_us, noise, want_media)
                if out.media is not None and self.c.media is not None:  # (on this thread, as the frame is read)
                    self.c.media.frame(out.media[0], time_us, self.c.pose_of(copy), out.media[1])
                    out.media = None
                answer.put((copy, out))
            except BaseException as exc:
                answer.put(exc)
        if pipeline is not None:
            pipeline.camera.close()


class ForkedChild:
    """A child forked from this process (the Popen calls :class:`ProcessWorker` makes of it)."""

    def __init__(self, pid: int) -> None:
        self.pid, self.returncode = pid, None

    def poll(self) -> int | None:
        if self.returncode is None:
            pid, status = os.waitpid(self.pid, os.WNOHANG)
            if pid:
                self.returncode = os.waitstatus_to_exitcode(status)
        return self.returncode

    def kill(self) -> None:
        if self.poll() is None:
            os.kill(self.pid, signal.SIGKILL)

    def wait(self) -> int | None:
        if self.returncode is None:
            self.returncode = os.waitstatus_to_exitcode(os.waitpid(self.pid, 0)[1])
        return self.returncode


class ProcessWorker:
    """The frames in a child process of their own (module docstring).  ``fork``: fork it from this process (the
    model and every import inherited: it answers at once), which only a process that has not yet rendered or run
    OpenCV may do (the simulator, building its world); otherwise a fresh interpreter is started (0.4 s of imports,
    overlapping the simulator's start-up)."""

    def __init__(self, companion: LockstepCompanion, fork: bool = False) -> None:
        self.c = companion
        self._state = StateCopy(companion.model)
        self._in_flight = 0
        self._sending: threading.Thread | None = None
        ours, theirs = socket.socketpair()
        if fork:
            pid = os.fork()
            if pid == 0:  # the child: its own session (a signal to the simulator's group must not end it early)
                ours.close()
                os.setsid()
                code = 1
                try:
                    _serve(Connection(theirs.detach()), companion)
                    code = 0
                finally:
                    os._exit(code)  # (none of the simulator's exit handlers)
            self._proc: subprocess.Popen | ForkedChild = ForkedChild(pid)
            theirs.close()
            self._conn = Connection(ours.detach())
            return
        env = dict(os.environ, PYTHONPATH=os.pathsep.join(p for p in sys.path if isinstance(p, str)))
        self._proc = subprocess.Popen(  # (this module's main: the same code as this process's, by its sys.path)
            [sys.executable, "-m", __name__, str(theirs.fileno())],
            pass_fds=(theirs.fileno(),), stdin=subprocess.DEVNULL, env=env,
            start_new_session=True,  # (a signal to the simulator's group must not end it before its last answer)
        )  # fmt: skip
        theirs.close()
        self._conn = Connection(ours.detach())
        # The companion's arguments go while the child imports (0.4 s), not blocking the simulator's start-up; the
        # first capture waits for them to have gone.
        args = companion.constructor_args()
        self._sending = threading.Thread(target=self._conn.send, args=(args,), daemon=True)
        self._sending.start()

    def submit(self, data: mujoco.MjData, time_us: int, noise: float, want_media: bool) -> bool:
        if self._in_flight >= IN_FLIGHT:
            return False
        if self._sending is not None:
            self._sending.join()
            self._sending = None
        self._conn.send((time_us, noise, want_media, self._state.pack(data)))
        self._in_flight += 1
        return True

    def answer(self, keepalive: Callable[[], None] | None, every_s: float) -> FrameAnswer:
        while not self._conn.poll(every_s):
            if keepalive is not None:
                keepalive()
            if self._proc.poll() is not None:
                raise RuntimeError(f"vision companion process ended (exit code {self._proc.returncode})")
        result = self._conn.recv()
        self._in_flight -= 1
        if isinstance(result, BaseException):
            raise RuntimeError("vision companion failed") from result
        return result

    def close(self) -> CompanionStats | None:
        """End the child; its statistics of the frames (the parent kept only its own wait)."""
        stats = None
        if self._sending is not None:
            self._sending.join()
        try:
            # Everything before the statistics is an answer never released (the flight ended first), counted or not:
            # a SIGTERM between a job's send and its count leaves one more in the pipe than _in_flight says.
            self._conn.send(None)
            while stats is None and self._conn.poll(10.0):
                message = self._conn.recv()
                if not isinstance(message, (FrameAnswer, BaseException)):
                    stats = message
        except (EOFError, OSError):
            pass
        self._conn.close()  # (the child ends on its own once it has answered; only a silent one is killed)
        if stats is None:
            self._proc.kill()
        if stats is None or isinstance(self._proc, ForkedChild):  # (a forked child exits at once: reaped)
            self._proc.wait()
        return stats


def _child_main(conn: Connection) -> None:
    """A started child: the companion rebuilt from its constructor's arguments (the first message; no worker of its
    own), then :func:`_serve`."""
    from sitl.companion import LockstepCompanion

    try:
        c = LockstepCompanion(*conn.recv(), worker=False)
    except (EOFError, OSError, KeyboardInterrupt):
        return
    _serve(conn, c)


def _serve(conn: Connection, c: LockstepCompanion) -> None:
    """The child's loop: one answer per job in order, then its statistics when told to stop (None); it ends when
    the simulator's end closes."""
    data = mujoco.MjData(c.model)
    state = StateCopy(c.model)
    c.stats = type(c.stats)()  # (a forked child's would start from the parent's: its own, from zero)
    try:
        pipeline, error = c.open_pipeline(), None
    except BaseException as exc:
        pipeline, error = None, exc
    try:
        while (job := conn.recv()) is not None:
            time_us, noise, want_media, packed = job
            if pipeline is None:
                conn.send(error)
                continue
            try:
                state.unpack(packed, data)
                conn.send(c.process_frame(pipeline, data, time_us, noise, want_media))
            except BaseException as exc:
                conn.send(exc)
        conn.send(c.stats)
    except (EOFError, OSError, KeyboardInterrupt):
        pass  # the simulator is gone
    finally:
        if pipeline is not None:
            pipeline.camera.close()


def new_worker(companion: LockstepCompanion, in_process: bool, fork: bool = False) -> ThreadWorker | ProcessWorker:
    """The worker ``SIM_CAM_PROC`` asks for (1: a process, forked from this one with ``fork``)."""
    return ProcessWorker(companion, fork) if in_process else ThreadWorker(companion)


if __name__ == "__main__":  # the worker process (ProcessWorker): its end of the socket pair is argv[1]
    _child_main(Connection(int(sys.argv[1])))
