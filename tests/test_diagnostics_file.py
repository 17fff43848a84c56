"""tests/e2e_diagnostics.keep: a failed e2e test's sections go to the flake hunt's file (E2E_DIAGNOSTICS), appended."""

import e2e_diagnostics


def test_sections_are_appended_to_the_file_the_environment_names(tmp_path, monkeypatch):
    path = tmp_path / "diagnostics-3.txt"
    monkeypatch.setenv("E2E_DIAGNOSTICS", str(path))
    e2e_diagnostics.keep("tests/test_a.py::test_x", "call", [("instance 7 sitl (running): last lines", "t=1 s\nt=2 s")])
    e2e_diagnostics.keep("tests/test_b.py::test_y", "teardown", [])
    text = path.read_text()
    assert text.startswith("===== tests/test_a.py::test_x (call)\n----- instance 7 sitl (running): last lines\nt=1 s\n")
    assert "===== tests/test_b.py::test_y (teardown)" in text


def test_without_the_variable_nothing_is_written(tmp_path, monkeypatch):
    monkeypatch.delenv("E2E_DIAGNOSTICS", raising=False)
    monkeypatch.chdir(tmp_path)
    e2e_diagnostics.keep("tests/test_a.py::test_x", "call", [("t", "x")])
    assert list(tmp_path.iterdir()) == []
