"""The configuration: one typed source of truth, TOML in and out, precedence, errors naming the key."""

import json
import tomllib

import pytest

from weldseam.config import PlanConfig, config_to_toml, effective_config, read_config_file, with_overrides
from weldseam.errors import InputError


def test_toml_of_a_config_reads_back_to_the_same_config():
    changed = with_overrides(
        PlanConfig(),
        {
            "normals": {"radius_m": 0.008},
            "segment": {"threshold": 0.05},
            "condition": {"crop_min_m": [0, -0.1, 0.0], "crop_max_m": [0.2, 0.1, 0.05]},
            "smooth": {"enabled": False},
            "output": {"rotation": "quat"},
        },
    )
    for config in (PlanConfig(), changed):
        assert with_overrides(PlanConfig(), tomllib.loads(config_to_toml(config))) == config


def test_precedence_is_command_line_then_file_then_defaults(tmp_path):
    file = tmp_path / "cell.toml"
    file.write_text("[normals]\nradius_m = 0.008\n[thinning]\niterations = 12\n")
    from_file = effective_config(file, {})
    assert from_file.normals.radius_m == 0.008 and from_file.thinning.iterations == 12
    assert from_file.descriptor == PlanConfig().descriptor
    both = effective_config(file, {"normals": {"radius_m": 0.007}})
    assert both.normals.radius_m == 0.007 and both.thinning.iterations == 12


def test_a_path_json_is_a_config_that_reproduces_its_run(tmp_path):
    config = with_overrides(PlanConfig(), {"pairing": {"max_width_m": 0.05}, "segment": {"threshold": 0.1}})
    from weldseam.config import config_to_dict

    record = tmp_path / "path.json"
    record.write_text(json.dumps({"version": "x", "params": config_to_dict(config), "seams": []}))
    assert effective_config(record, {}) == config


@pytest.mark.parametrize(
    ("text", "fragment"),
    [
        ("[normals]\nradius = 0.008\n", "unknown config key normals.radius"),
        ("[normal]\nradius_m = 0.008\n", "unknown config section 'normal'"),
        ("[normals]\nradius_m = 'big'\n", "normals.radius_m must be a number"),
        ("[thinning]\niterations = 2.5\n", "thinning.iterations must be an integer"),
        ("[extend]\nmax_hole_m = -0.01\n", "extend.max_hole_m must be a finite number >= 0, got -0.01"),
        ("[thinning]\niterations = -3\n", "thinning.iterations must be a finite number >= 0, got -3"),
        ("[condition]\nvoxel_m = nan\n", "condition.voxel_m must be a finite number >= 0, got nan"),
        ("[descriptor]\nvariant = 'paper'\n", "descriptor.variant must be one of released, thesis"),
        ("[normals\nradius_m = 0.008\n", "not valid TOML"),
        ("radius_m = 0.008\n", "expected [section] tables"),
    ],
)
def test_a_bad_config_file_is_named_with_its_problem(tmp_path, text, fragment):
    file = tmp_path / "bad.toml"
    file.write_text(text)
    with pytest.raises(InputError) as error:
        read_config_file(file)
    assert str(error.value).startswith(f"{file}: ")
    assert fragment in str(error.value)


def test_a_missing_config_file_is_named(tmp_path):
    with pytest.raises(InputError, match="config file not found"):
        read_config_file(tmp_path / "nowhere.toml")


@pytest.mark.parametrize(
    ("overrides", "message"),
    [
        ({"condition": {"working_voxel_m": 0.0001}},
         "condition.working_voxel_m 0.0001 is below condition.voxel_m 0.001: the working cloud coarsens the fine "
         "one, so its voxel must be at least as large"),
        ({"condition": {"voxel_m": 0.0001, "working_voxel_m": 0.0001}},
         "smooth.radius_m 0.006 spans 60 working voxels (condition.working_voxel_m 0.0001), at most 8: each "
         "neighbourhood would hold ~11310 points and the memory grows with that; raise condition.working_voxel_m "
         "to at least 0.00075 or lower smooth.radius_m"),
        ({"smooth": {"enabled": False}, "condition": {"voxel_m": 0.0001, "working_voxel_m": 0.0001}},
         "normals.radius_m 0.006 spans 60 working voxels"),
        ({"descriptor": {"radius_m": 0.002}},
         "descriptor.radius_m 0.002 is below condition.working_voxel_m 0.0025: the neighbourhood would hold no "
         "neighbours"),
        ({"boundary": {"radius_m": 0.021}}, "boundary.radius_m 0.021 spans 8.4 working voxels"),
        ({"grid": {"leaf_m": 0}}, "grid.leaf_m must be above 0, got 0.0"),
        ({"condition": {"voxel_m": 0.0}}, "condition.voxel_m must be above 0, got 0.0"),
        ({"order": {"link_m": 0.002}}, "order.link_m 0.002 is below grid.leaf_m 0.003"),
        ({"resample": {"spacing_m": 0.00005}}, "resample.spacing_m 5e-05 is below 0.0001 m"),
        ({"segment": {"line_valley_length_m": 0.003}},
         "segment.line_valley_length_m 0.003 must be 0 (off) or 2-40 working voxels (0.005-0.1 m at "
         "condition.working_voxel_m 0.0025)"),
        ({"segment": {"line_valley_length_m": 0.2}}, "segment.line_valley_length_m 0.2 must be 0 (off) or 2-40"),
        ({"segment": {"line_valley_min_crease_deg": 0.0}}, "segment.line_valley_min_crease_deg must be above 0"),
        ({"segment": {"wide_valley_radius_m": 0.0}},
         "segment.line_valley_length_m needs segment.wide_valley_radius_m above 0"),
    ],
)
def test_parameters_that_cannot_work_together_are_refused_naming_the_key(overrides, message):
    with pytest.raises(InputError) as error:
        effective_config(None, overrides)
    assert str(error.value).startswith(message)


def test_the_relations_allow_the_defaults_and_their_limits():
    effective_config(None, {})
    limits = {"condition": {"voxel_m": 0.00075, "working_voxel_m": 0.00075},
              **{section: {"radius_m": 0.006} for section in ("smooth", "normals", "descriptor", "boundary")},
              "thinning": {"radius_m": 0.00075}, "segment": {"cluster_tolerance_m": 0.006},
              "order": {"link_m": 0.003}, "resample": {"spacing_m": 0.0001}}
    limits["segment"]["line_valley_length_m"] = 2 * 0.00075
    config = effective_config(None, limits)
    assert config.normals.radius_m == 8 * config.condition.working_voxel_m
    assert effective_config(None, {"segment": {"line_valley_length_m": 0.0, "wide_valley_radius_m": 0.0}})
