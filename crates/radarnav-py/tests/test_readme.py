"""The README's Python example runs as written."""

import os
import re

HERE = os.path.dirname(os.path.abspath(__file__))


def test_the_readme_example_runs(tmp_path, monkeypatch):
    with open(os.path.join(HERE, "..", "..", "..", "README.md"), encoding="utf-8") as f:
        readme = f.read()
    section = readme[readme.index("## Python and Gymnasium") :]
    code = re.search(r"```python\n(.*?)```", section, re.S).group(1)
    monkeypatch.chdir(tmp_path)
    scope = {}
    exec(compile(code, "README.md", "exec"), scope)
    assert scope["grid"].ndim == 2
    assert scope["summary"]["outcome"] == "reached"
    assert (tmp_path / "out" / "py" / "map_radar.png").exists()
