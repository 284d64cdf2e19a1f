"""weldseam in a real shell pipeline: data on stdout only, messages on stderr."""

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
WELDSEAM = f"{sys.executable} -m weldseam.cli"


def shell(command: str):
    return subprocess.run(["bash", "-c", f"set -o pipefail; {command}"], cwd=ROOT, capture_output=True, timeout=180)


def test_a_ply_on_stdin_to_csv_on_stdout_through_other_processes():
    result = shell(
        f"cat samples/v_butt.ply | {WELDSEAM} plan - --camera-pose samples/v_butt.pose.json -o - --format csv"
        " | tail -n +2 | cut -d, -f1 | sort | uniq -c"
    )
    assert result.returncode == 0, result.stderr
    (line,) = result.stdout.decode().strip().splitlines()  # one seam: every row has seam 0
    count, seam = line.split()
    assert seam == "0" and int(count) > 80
    assert "1 seam(s)" in result.stderr.decode()


def test_quiet_pipelines_print_nothing_but_data_and_errors_still_reach_stderr(tmp_path):
    result = shell(
        f"{WELDSEAM} plan samples/v_butt.ply --camera-pose samples/v_butt.pose.json -o - -q | tee {tmp_path}/p.csv"
        f" | wc -l && {WELDSEAM} compare {tmp_path}/p.csv samples/golden/v_butt.json --tol-mm 0.001 -q > /dev/null"
    )
    assert result.returncode == 0, result.stderr
    assert result.stderr == b""
    assert (tmp_path / "p.csv").read_text().startswith("seam,x,y,z,rx,ry,rz\n")
    failing = shell(f"cat samples/v_butt.ply | head -c 3000 | {WELDSEAM} plan - -o - | wc -l")
    assert failing.returncode == 2
    assert failing.stdout.decode().strip() == "0"
    assert failing.stderr.decode().startswith("Error: stdin: truncated PLY")
