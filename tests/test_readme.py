"""Every weldseam command the README shows works as shown."""

import re
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def readme_commands():
    text = (ROOT / "README.md").read_text()
    blocks = re.findall(r"```sh\n(.*?)```", text, flags=re.S)
    lines = "\n".join(blocks).replace("\\\n", " ").splitlines()
    return [line.split("  #")[0].strip() for line in lines if ".venv/bin/weldseam" in line]


def test_the_readme_shows_planning_commands():
    assert len(readme_commands()) >= 3


@pytest.mark.parametrize("command", readme_commands())
def test_readme_command_works(command, tmp_path):
    for name in ("samples", ".venv"):
        (tmp_path / name).symlink_to(ROOT / name)
    result = subprocess.run(["bash", "-c", f"set -o pipefail; {command}"], cwd=tmp_path, capture_output=True, timeout=120)
    assert result.returncode == 0, result.stderr.decode()
    outputs = [tmp_path / name for name in ("path.json", "path.csv") if (tmp_path / name).exists()]
    assert outputs and all(path.stat().st_size > 100 for path in outputs)
