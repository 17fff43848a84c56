"""``flight-demo``'s closing line names the logs the flight left: ``.frames.npy`` only when there is one."""

from __future__ import annotations

from types import SimpleNamespace

from gcs.launcher.demo import logs_line


def test_the_logs_line_names_the_camera_frames_only_when_written(tmp_path):
    stack = SimpleNamespace(log_dir=tmp_path)
    (tmp_path / "quad_x-0.truth.npy").write_bytes(b"")
    assert "(.ulg, .tlog, .truth.npy) in" in logs_line(stack)
    (tmp_path / "quad_x-0.frames.npy").write_bytes(b"")
    line = logs_line(stack)
    assert f"(.ulg, .tlog, .truth.npy, .frames.npy) in {tmp_path}" in line
    assert line.endswith(f"plot {tmp_path}")
