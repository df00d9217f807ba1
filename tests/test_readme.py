"""The README's scripting example runs as written."""

import re
from pathlib import Path

README = Path(__file__).resolve().parent.parent / "README.md"


def test_scripting_example_runs(capsys):
    text = README.read_text(encoding="utf-8")
    section = text.split("## Scripting", 1)[1]
    blocks = re.findall(r"```python\n(.*?)```", section, flags=re.S)
    assert blocks, "the Scripting section has no python example"
    exec(compile(blocks[0], "README.md (Scripting)", "exec"), {})
    out = capsys.readouterr().out
    assert "shoulder" in out
    assert "True" in out


def test_readme_names_the_two_commands():
    text = README.read_text(encoding="utf-8")
    assert "./scripts/run" in text
    assert "./scripts/check" in text
