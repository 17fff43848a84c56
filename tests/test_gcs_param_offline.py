"""The pieces of ``gcs param`` that need no vehicle: sub-commands, the progress bar, applying entries,
and the full download's logic against a fake link that loses messages.

``gcs param`` against a real vehicle is tested in tests/test_e2e_params.py.
"""

from __future__ import annotations

import io
import time

import pytest

from autopilot.param_storage import apply_entries
from gcs.__main__ import build_parser
from gcs.param_cli import ProgressBar
from mavsim_core.param_encoding import REAL32
from params.param_file import MAVPROXY, QGC, ParamEntry

# --------------------------------------------------------------------------- gcs param (no vehicle)


def test_gcs_param_sub_commands_parse():
    p = build_parser()
    a = p.parse_args(["param", "save", "out.params", "--format", "mavproxy"])
    assert (a.param_command, a.file, a.format) == ("save", "out.params", MAVPROXY)
    assert p.parse_args(["param", "save", "x"]).format == QGC
    assert p.parse_args(["param", "list", "MPC_*", "MC_*"]).patterns == ["MPC_*", "MC_*"]
    assert p.parse_args(["param", "load", "f"]).param_command == "load"
    assert p.parse_args(["param", "diff", "f"]).param_command == "diff"
    with pytest.raises(SystemExit):
        p.parse_args(["param", "save", "x", "--format", "json"])


class FakeTty(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_progress_bar_on_a_terminal_only():
    tty = FakeTty()
    bar = ProgressBar(tty, width=10, min_interval_s=0.0)
    for i in range(1, 5):
        bar(i, 4)
    bar.finish("downloaded 4 parameters in 0.01 s")
    out = tty.getvalue()
    assert "\r[##........] 1/4 parameters" in out and "\r[##########] 4/4 parameters" in out
    assert out.endswith("\rdownloaded 4 parameters in 0.01 s\n")
    plain = io.StringIO()
    bar = ProgressBar(plain)
    bar(1, 4)
    bar.finish("downloaded 4 parameters in 0.01 s")
    assert plain.getvalue() == "downloaded 4 parameters in 0.01 s\n"


def test_apply_entries_counts(store):
    applied, problems = apply_entries(
        store, [ParamEntry("MPC_XY_P", 1.5, REAL32, 1), ParamEntry("MPC_XY_P", 3.0, REAL32, 2)]
    )
    assert applied == 1 and [(p.line, p.reason) for p in problems] == [(2, "MPC_XY_P: 3 outside range [0, 2] 1/s")]


# --------------------------------------------------------------------------- full download logic (fake link)


class FakeVehicleLink:
    """Stands in for a VehicleClient: a vehicle of ``count`` parameters that loses some list messages.

    The list stream drops the indices in ``drop``; reads by index are answered.  With
    ``rename_at`` that index is sent twice, the second time under another name (an inconsistent vehicle).
    """

    def __init__(
        self, count: int, drop: set[int] = frozenset(), answer_reads: bool = True, rename_at: int | None = None
    ) -> None:
        from pymavlink.dialects.v20 import common as mavlink

        self.mavlink = mavlink
        self.encoder = mavlink.MAVLink(None, 1, 1)
        self.count, self.drop, self.answer_reads, self.rename_at = count, set(drop), answer_reads, rename_at
        self.target_system = self.target_component = 1
        self._param_types: dict[str, int] = {}
        self._listeners: list = []
        self.queue: list = []
        self.reads: list[int] = []
        self.answers: dict[int, int] = {}
        self.conn = self
        self.mav = self

    # VehicleClient's surface used by download_parameters
    def _timeout(self, timeout_s):
        return 2.0 if timeout_s is None else timeout_s

    def add_listener(self, cb):
        self._listeners.append(cb)

    def remove_listener(self, cb):
        self._listeners.remove(cb)

    def pump(self, timeout_s=0.0):
        if not self.queue:
            time.sleep(min(timeout_s, 0.01))
        msgs, self.queue = self.queue, []
        for m in msgs:
            for cb in list(self._listeners):
                cb(m)
        return msgs

    def drain(self):
        self.pump(0.0)

    def param_request_list_send(self, sysid, compid):
        for i in range(self.count):
            if i not in self.drop:
                self.queue.append(self._value(i))
            if i == self.rename_at:
                self.queue.append(self._value(i))

    def param_request_read_send(self, sysid, compid, name, index):
        self.reads.append(index)
        if self.answer_reads:
            self.queue.append(self._value(index))

    def _value(self, i: int):
        self.answers[i] = self.answers.get(i, 0) + 1
        name = f"P_{i:03d}" if not (i == self.rename_at and self.answers[i] > 1) else "RENAMED"
        msg = self.mavlink.MAVLink_param_value_message(name.encode(), float(i), REAL32, self.count, i)
        msg.pack(self.encoder)
        return msg


def test_download_re_reads_missing_indices_by_index():
    from gcs.plugins.param import DownloadStats, download_parameters

    link = FakeVehicleLink(45, drop={3, 17, 44})
    progress: list[tuple[int, int]] = []
    stats = DownloadStats()
    params = download_parameters(link, lambda got, n: progress.append((got, n)), 5.0, stats)
    assert [p.index for p in params] == list(range(45)) and params[17].name == "P_017" and params[17].value == 17.0
    assert sorted(link.reads) == [3, 17, 44] and stats.re_requested == 3
    assert progress[-1] == (45, 45) and len(progress) == 45
    assert link._param_types["P_003"] == REAL32


def test_download_times_out_naming_missing_indices_and_catches_inconsistency():
    from gcs.errors import GcsTimeout, ParamListError
    from gcs.plugins.param import download_parameters

    with pytest.raises(GcsTimeout, match="43 of 45 received, missing indices 3, 17"):
        download_parameters(FakeVehicleLink(45, drop={3, 17}, answer_reads=False), timeout_s=0.8)
    with pytest.raises(ParamListError, match="index 3 was P_003, now RENAMED"):
        download_parameters(FakeVehicleLink(10, rename_at=3), timeout_s=2.0)
