"""The README's Python example runs as written (on this session's release instead of
build/quickstart)."""

import re
import subprocess
import sys

from conftest import REPO


def readme_snippet() -> str:
    text = (REPO / "README.md").read_text()
    section = text.split("\n## Python", 1)[1]
    return re.search(r"```python\n(.*?)```", section, re.S).group(1)


def test_readme_example_runs(release_dir):
    code = readme_snippet()
    assert "build/quickstart" in code and len(code.strip().splitlines()) <= 20
    code = code.replace("build/quickstart", str(release_dir))
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=600)
    assert p.returncode == 0, p.stderr
    assert "recognized towel" in p.stdout and "registration error" in p.stdout
