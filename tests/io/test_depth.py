from pathlib import Path

from weldseam.io.depth import read_intrinsics, write_intrinsics
from weldseam.synthetic.sensor import D415
from weldseam.types import Intrinsics

SAMPLES = Path(__file__).resolve().parents[2] / "samples"


def test_written_intrinsics_read_back_unchanged(tmp_path):
    odd = Intrinsics(width=848, height=480, fx=421.5, fy=421.25, cx=423.9, cy=239.1, depth_scale=4000.0)
    write_intrinsics(tmp_path / "odd.json", odd)
    assert read_intrinsics(tmp_path / "odd.json") == odd


def test_the_bundled_intrinsics_are_what_the_writer_writes(tmp_path):
    write_intrinsics(tmp_path / "d415.json", D415)
    assert (tmp_path / "d415.json").read_bytes() == (SAMPLES / "d415.intrinsics.json").read_bytes()
