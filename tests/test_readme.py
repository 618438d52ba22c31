"""The README's Python API example runs as written (with a shorter training budget)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

README = Path(__file__).resolve().parents[1] / "README.md"


def api_example() -> str:
    """The first ```python block under the README's "## Python API" heading."""
    text = README.read_text()
    section = text.split("## Python API", 1)[1]
    match = re.search(r"```python\n(.*?)```", section, flags=re.S)
    assert match, "README: no python block under '## Python API'"
    return match.group(1)


def test_readme_api_example_runs(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys) -> None:
    code = api_example()
    assert len(code.strip().splitlines()) <= 12  # the issue asks for a ~10-line example
    budget = re.search(r"model\.learn\((\d[\d_]*)", code)
    assert budget, "README example: model.learn(<steps>, ...) not found"
    code = code.replace(budget.group(0), "model.learn(600")  # same code, fewer steps
    monkeypatch.chdir(tmp_path)
    exec(compile(code, str(README), "exec"), {"__name__": "readme_example"})
    assert (tmp_path / "gsn_blind_soccer.zip").exists()
    assert any((tmp_path / "runs" / "tb").rglob("events.out.tfevents.*"))
    printed = capsys.readouterr().out
    assert "'mean_return'" in printed and "'n_episodes': 100" in printed


def test_readme_silence_example_runs() -> None:
    """The README's example that closes an environment's own channel builds what it says."""
    blocks = re.findall(r"```python\n(.*?)```", README.read_text(), flags=re.S)
    code = next(b for b in blocks if "silence=NativeChannel" in b)
    namespace: dict = {}
    exec(compile(code, str(README), "exec"), namespace)
    env = namespace["env"]
    assert env.observation_space.shape == (2, 11 + 2 + 4)  # 10 heard entries gone, our 4 added
    assert env.action_space.shape == (2, 5 + 4)  # 10 said entries gone
