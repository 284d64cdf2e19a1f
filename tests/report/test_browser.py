"""The page renders in a real browser (Debian's chromium, headless, network closed)."""

import shutil
import subprocess

import numpy as np
import pytest
from PIL import Image

from weldseam.report import write_report

CHROMIUM = shutil.which("chromium")


@pytest.mark.skipif(CHROMIUM is None, reason="chromium not installed (make test installs it)")
def test_chromium_draws_the_scan_and_the_path(plate_and_path, tmp_path):
    points, paths, record = plate_and_path
    page = tmp_path / "report.html"
    write_report(points, paths, record, page, point_budget=20000)
    shot = tmp_path / "shot.png"
    subprocess.run(
        [
            CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
            "--disable-component-update", "--disable-sync", "--no-first-run", f"--user-data-dir={tmp_path / 'profile'}",
            "--host-resolver-rules=MAP * ~NOTFOUND", "--window-size=1200,900", "--virtual-time-budget=5000",
            f"--screenshot={shot}", page.as_uri(),
        ],
        capture_output=True, timeout=120, check=True,
    )
    image = np.asarray(Image.open(shot).convert("RGB")).astype(int)
    assert image.std() > 10  # not a blank page
    path_red = np.all(np.abs(image - [230, 25, 75]) <= 30, axis=2).sum()
    plate = np.all(np.abs(image - [33, 145, 140]) <= 60, axis=2).sum()  # mid-ramp colours of the scan
    assert path_red > 100 and plate > 1000
