"""Every weldseam command the README shows works as shown.

Each ```sh block that runs `.venv/bin/weldseam` is run line by line, in order, in a fresh
folder that sees `samples/` and `.venv/` (later lines may use what earlier ones wrote).
Every line must succeed, and every file it names after `-o`, `--png`, `--script` or `>`
must exist and not be empty (a folder: not empty). A line ending in `&` starts a server for the lines after it;
it is stopped when the block is done.
"""

import re
import signal
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
OUTPUT = re.compile(r"(?:-o|--output|--png|--script|>)\s+(?!-\s|-$)(\S+)")


def readme_blocks() -> list[list[str]]:
    text = (ROOT / "README.md").read_text()
    blocks = []
    for block in re.findall(r"```sh\n(.*?)```", text, flags=re.S):
        lines = [line.split("  #")[0].strip() for line in block.replace("\\\n", " ").splitlines()]
        lines = [line for line in lines if line and not line.startswith("#")]
        if any(".venv/bin/weldseam" in line for line in lines):
            blocks.append(lines)
    return blocks


def test_the_readme_shows_planning_commands():
    assert sum(".venv/bin/weldseam plan" in line for block in readme_blocks() for line in block) >= 3


@pytest.mark.parametrize("block", readme_blocks(), ids=lambda block: block[0][:60])
def test_readme_block_works(block, tmp_path):
    for name in ("samples", ".venv"):
        (tmp_path / name).symlink_to(ROOT / name)
    servers = []
    try:
        for line in block:
            if line.endswith("&"):
                servers.append(subprocess.Popen(["bash", "-c", f"exec {line[:-1]}"], cwd=tmp_path))
                continue
            result = subprocess.run(
                ["bash", "-c", f"set -o pipefail; {line}"], cwd=tmp_path, capture_output=True, timeout=180
            )
            assert result.returncode == 0, f"{line}\n{result.stderr.decode()}"
            for name in OUTPUT.findall(line):
                target = tmp_path / name
                written = any(target.iterdir()) if target.is_dir() else target.is_file() and target.stat().st_size > 0
                assert written, f"{line}: nothing written to {name}"
    finally:
        for server in servers:
            server.send_signal(signal.SIGINT)
            server.wait(timeout=30)


def test_the_readme_and_the_weld_path_name_every_joint_kind():
    from weldseam.pipeline.joints import JointKind
    from weldseam.types import WeldPath

    listed = re.search(r"joint \(([^)]*)\)", (ROOT / "README.md").read_text()).group(1)  # what JSON holds
    for kind in JointKind:
        assert f"`{kind.value}`" in listed and f'"{kind.value}"' in WeldPath.__doc__
