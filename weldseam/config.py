"""The one place where pipeline parameters and their defaults live.

One frozen dataclass per stage, named like the stage module; lengths in metres (`_m`),
angles in degrees (`_deg`). The CLI options and the output record derive from these.
"""

from __future__ import annotations

import dataclasses
import json
import math
import tomllib
from dataclasses import dataclass, field, fields
from pathlib import Path

from weldseam.errors import InputError


def _param(default, help_text: str, choices: tuple[str, ...] = ()):
    return field(default=default, metadata={"help": help_text, "choices": choices})


@dataclass(frozen=True)
class ConditionConfig:
    voxel_m: float = _param(0.001, "fine voxel size; points in one voxel merge to their centroid")
    working_voxel_m: float = _param(
        0.0025, "coarser voxel for the neighbourhood stages (normals, descriptor, segmentation)"
    )
    crop_min_m: tuple[float, float, float] | None = _param(None, "crop box lower corner (base frame)")
    crop_max_m: tuple[float, float, float] | None = _param(None, "crop box upper corner (base frame)")
    outlier_fraction: float = _param(
        0.25, "drop working points with fewer neighbours than this fraction of the median count"
    )


@dataclass(frozen=True)
class MergeConfig:
    refine: bool = _param(True, "several frames: refine each frame's pose by ICP against the frames before it")
    icp_voxel_m: float = _param(0.004, "voxel of the points ICP aligns (and of the veil test)")
    icp_max_distance_m: float = _param(0.015, "largest pose error ICP corrects (its first pairing distance)")
    min_overlap: float = _param(
        0.2, "a frame whose share of points on the earlier frames' surface is below this keeps its pose"
    )
    dedup_voxel_m: float = _param(0.003, "de-duplication voxel: in each, only the frame with most points is kept")
    max_incidence_deg: float = _param(
        80.0, "patches seen more edge-on than this are flying-pixel veils at depth edges and are dropped"
    )


@dataclass(frozen=True)
class SmoothConfig:
    enabled: bool = _param(True, "bilateral smoothing along the normal (keeps creases)")
    radius_m: float = _param(0.006, "neighbourhood radius of the smoother")
    range_sigma_m: float | None = _param(
        None, "offset scale of the bilateral weight; default: 2 x the median |normal offset|"
    )


@dataclass(frozen=True)
class NormalsConfig:
    radius_m: float = _param(
        0.006, "PCA neighbourhood radius (the method's 10 mm blends creases 30 mm apart into one band)"
    )


@dataclass(frozen=True)
class DescriptorConfig:
    variant: str = _param(
        "released", "'released' (variance of cosines) or 'thesis' (angles, global term)", ("released", "thesis")
    )
    radius_m: float = _param(0.006, "neighbourhood radius of the gradient descriptor")


@dataclass(frozen=True)
class SegmentConfig:
    threshold: float | None = _param(None, "descriptor threshold; default: automatic (see segment.py)")
    min_crease_deg: float = _param(20.0, "automatic threshold: the weakest crease that counts as a seam")
    valleys: bool = _param(
        True, "also take valleys and ridges (the signed bend, on the crease line) as candidates, each on its own"
    )
    noise_factor: float = _param(
        2.0, "valleys: the bend must be at least this many times the scan's own bend noise (robust sigma)"
    )
    min_density: float = _param(
        0.25, "valleys: a point counts when this share of its neighbours bends the same way (noise is scattered)"
    )
    wide_valley_radius_m: float = _param(
        0.02, "valleys: also seek valleys over this radius (a shallow valley between tubes is no deeper than "
        "a sensor's ripple over descriptor.radius_m); 0: off"
    )
    line_valley_length_m: float = _param(
        0.03, "valleys: also average each point's valley depth over a line this long along the valley (a valley "
        "between tubes too shallow for either radius stays along its length; noise does not), sought and traced "
        "with the wide valleys (needs wide_valley_radius_m); 0: off"
    )
    line_valley_min_crease_deg: float = _param(
        6.5, "valleys along their length: the weakest bend (as min_crease_deg) their averaged depth must show"
    )
    occluded_ends: bool = _param(
        True, "a single view: also take surface ends past which the camera sees a wall's top (a T-joint seen from "
        "above, its web's face too oblique to measure) as candidates"
    )
    gaps: bool = _param(
        True, "a single view: also take lines of missing pixels between two surfaces (a square butt's narrow "
        "opening, which bends nothing) as candidates, seeking square butts alone"
    )
    cluster_tolerance_m: float = _param(0.006, "Euclidean clustering distance between seam points")
    min_seam_length_m: float = _param(0.02, "candidate creases shorter than this are not traced")


@dataclass(frozen=True)
class BoundaryConfig:
    radius_m: float = _param(0.006, "neighbourhood radius; holes narrower than ~radius/3 are ignored")
    shift_ratio: float = _param(0.25, "boundary if the neighbour centroid is off by > ratio * radius")


@dataclass(frozen=True)
class PairingConfig:
    angle_tolerance_deg: float = _param(10.0, "partner direction within 90 +- this of the edge tangent")
    max_width_m: float = _param(0.06, "widest band that is paired across")
    width_tolerance: float = _param(0.25, "pairs wider or narrower than the local median by this fraction are dropped")


@dataclass(frozen=True)
class ThinningConfig:
    radius_m: float = _param(0.005, "centroid radius")
    iterations: int = _param(20, "centroid iterations")


@dataclass(frozen=True)
class GridConfig:
    leaf_m: float = _param(0.003, "voxel leaf that merges the thinned points")


@dataclass(frozen=True)
class OrderConfig:
    link_m: float = _param(0.008, "largest gap between consecutive seam points that is bridged")
    min_branch_m: float = _param(0.015, "side branches shorter than this are noise and pruned")


@dataclass(frozen=True)
class SectionConfig:
    half_width_m: float = _param(0.025, "cross-section reach from the seam (radius of the window)")
    slab_m: float = _param(0.003, "cross-section thickness along the seam")


@dataclass(frozen=True)
class JointsConfig:
    face_radius_m: float = _param(0.012, "how far beside the seam the faces that set the torch axis are fitted")
    groove_min_depth_m: float = _param(0.0015, "shallowest groove that counts")
    fillet_min_leg_m: float = _param(0.012, "shortest face of a fillet (shorter: a plate edge on a table)")
    lap_torch_split_deg: float = _param(
        45.0, "lap: torch angle from the bottom plate's surface (45: the bisector; welding practice ~60)"
    )
    gap_min_m: float = _param(0.0005, "narrowest opening of a square butt joint (I-groove) that counts")
    gap_max_m: float = _param(0.004, "widest opening of a square butt joint (I-groove)")


@dataclass(frozen=True)
class TraceConfig:
    min_valid_fraction: float = _param(0.6, "a candidate whose sections fit one joint less often is not a seam")
    max_gap_m: float = _param(0.012, "a run of failed sections longer than this splits a traced seam")
    max_offset_m: float = _param(0.0015, "a seam point this far from the line through its 5 nearest neighbours is dropped")
    max_turn_deg: float = _param(8.0, "a section whose torch axis turns this far from its 5 neighbours' is dropped")


@dataclass(frozen=True)
class SupportConfig:
    enabled: bool = _param(True, "a seam on the support plane (the table) or beside it is no joint (a part rests there)")
    tolerance_m: float = _param(0.002, "how far a point may lie from the support plane and be on it")
    below_fraction: float = _param(0.05, "share of points allowed beyond the support plane (noise, outliers)")


@dataclass(frozen=True)
class JoinConfig:
    overlap_m: float = _param(0.004, "traces closer than this to a longer one are the same seam")
    join_m: float = _param(0.025, "pieces of one seam whose facing ends are this close are joined")
    max_turn_deg: float = _param(
        100.0, "pieces meeting at up to this turn are joined (a groove over a block edge turns 90)"
    )


@dataclass(frozen=True)
class ExtendConfig:
    step_m: float = _param(0.002, "distance between the sections an extension tries")
    max_skip_m: float = _param(0.012, "longest run of failed sections an extension steps over")
    max_extension_m: float = _param(0.3, "how far an open seam end may be extended section by section")
    max_hole_m: float = _param(
        0.05, "longest hole in the scan (no data on the seam line) a seam is carried across, interpolated"
    )
    edge_search_m: float = _param(0.012, "how far ahead an edge the seam turns over (90 degrees) is sought")
    part_end_reach_m: float = _param(0.012, "seeing past the part's end this far ahead stops the seam there")


@dataclass(frozen=True)
class SplitConfig:
    junction_m: float = _param(0.0125, "a seam end this close to another seam's interior is a junction on it")
    min_branch_m: float = _param(0.015, "a piece shorter than this is no branch and splits nothing")
    min_seam_length_m: float = _param(0.02, "seams shorter than this are dropped")
    min_inferred_length_m: float = _param(
        0.05, "a seam with no clean fit of its sections (only one face seen, rough, bridged) shorter than this is dropped"
    )


@dataclass(frozen=True)
class ResampleConfig:
    spacing_m: float = _param(0.002, "pose spacing along the seam (arc length)")
    smoothing_m: float = _param(0.003, "Gaussian sigma (arc length) that smooths seam points before resampling")


DIRECTION_RULES = ("+x", "-x", "+y", "-y", "+z", "-z", "away-from-robot", "toward-robot", "start-point")


@dataclass(frozen=True)
class DirectionConfig:
    rule: str = _param(
        "+x",
        "travel direction: along a base axis (+x -x +y -y +z -z), away-from-robot or toward-robot (the base "
        "origin), or start-point (start nearest start_m); see weldseam/pipeline/direction.py",
        DIRECTION_RULES,
    )
    start_m: tuple[float, float, float] | None = _param(
        None, "rule start-point: each seam starts at the end (a closed seam at the pose) nearest this point"
    )
    closed_sense: str = _param(
        "ccw", "a closed seam turns counter-clockwise (ccw) or clockwise (cw) seen from the rule's direction",
        ("ccw", "cw"),
    )


@dataclass(frozen=True)
class OutputConfig:
    format: str = _param(
        "auto", "path file format: auto (from the extension; csv on stdout), json or csv", ("auto", "json", "csv")
    )
    rotation: str = _param(
        "rotvec", "CSV rotation columns: rotvec (UR rx,ry,rz) or quat (qx,qy,qz,qw)", ("rotvec", "quat")
    )


@dataclass(frozen=True)
class PlanConfig:
    condition: ConditionConfig = field(default_factory=ConditionConfig)
    merge: MergeConfig = field(default_factory=MergeConfig)
    smooth: SmoothConfig = field(default_factory=SmoothConfig)
    normals: NormalsConfig = field(default_factory=NormalsConfig)
    descriptor: DescriptorConfig = field(default_factory=DescriptorConfig)
    segment: SegmentConfig = field(default_factory=SegmentConfig)
    boundary: BoundaryConfig = field(default_factory=BoundaryConfig)
    pairing: PairingConfig = field(default_factory=PairingConfig)
    thinning: ThinningConfig = field(default_factory=ThinningConfig)
    grid: GridConfig = field(default_factory=GridConfig)
    order: OrderConfig = field(default_factory=OrderConfig)
    section: SectionConfig = field(default_factory=SectionConfig)
    joints: JointsConfig = field(default_factory=JointsConfig)
    trace: TraceConfig = field(default_factory=TraceConfig)
    support: SupportConfig = field(default_factory=SupportConfig)
    join: JoinConfig = field(default_factory=JoinConfig)
    extend: ExtendConfig = field(default_factory=ExtendConfig)
    split: SplitConfig = field(default_factory=SplitConfig)
    resample: ResampleConfig = field(default_factory=ResampleConfig)
    direction: DirectionConfig = field(default_factory=DirectionConfig)
    output: OutputConfig = field(default_factory=OutputConfig)


# Keys of weldseam 0.1's seam core that became the steps' own sections.
MOVED_KEYS = {
    "section.face_radius_m": "joints.face_radius_m",
    "section.groove_min_depth_m": "joints.groove_min_depth_m",
    "section.fillet_min_leg_m": "joints.fillet_min_leg_m",
    "section.min_valid_fraction": "trace.min_valid_fraction",
    "section.ignore_support_corners": "support.enabled",
    "section.max_gap_m": "trace.max_gap_m, extend.max_skip_m, extend.edge_search_m and extend.part_end_reach_m",
    "section.max_extension_m": "extend.max_extension_m",
    "section.max_hole_m": "extend.max_hole_m",
    "order.join_m": "join.join_m",
    "order.overlap_m": "join.overlap_m",
    "order.max_join_turn_deg": "join.max_turn_deg",
}


def config_to_dict(config: PlanConfig) -> dict:
    """Nested plain dict {section: {key: value}} (tuples as lists), for records and TOML."""
    return {
        f.name: {
            key: list(value) if isinstance(value, tuple) else value
            for key, value in dataclasses.asdict(getattr(config, f.name)).items()
        }
        for f in fields(config)
    }


def with_overrides(config: PlanConfig, overrides: dict[str, dict]) -> PlanConfig:
    """A copy of `config` with `{section: {key: value}}` applied; unknown keys and wrong types
    raise InputError naming `section.key`."""
    sections = {f.name: f for f in fields(config)}
    updated = {}
    for section_name, values in overrides.items():
        if section_name not in sections:
            raise InputError(f"unknown config section {section_name!r} (known: {', '.join(sections)})")
        section = getattr(config, section_name)
        known = {f.name: f for f in fields(section)}
        changes = {}
        for key, value in values.items():
            if key not in known:
                moved = MOVED_KEYS.get(f"{section_name}.{key}")
                raise InputError(f"unknown config key {section_name}.{key}" + (f" (now {moved})" if moved else ""))
            changes[key] = _coerce(f"{section_name}.{key}", getattr(section, key), known[key], value)
        updated[section_name] = dataclasses.replace(section, **changes)
    return dataclasses.replace(config, **updated)


def _coerce(name: str, current, spec: dataclasses.Field, value):
    default = spec.default
    sample = default if default is not None else current
    if value is None:
        if default is None:
            return None
        raise InputError(f"{name} cannot be empty")
    if isinstance(sample, bool) or spec.type == "bool":
        if isinstance(value, bool):
            return value
        raise InputError(f"{name} must be true or false, got {value!r}")
    if "tuple" in str(spec.type):
        if isinstance(value, (list, tuple)) and len(value) == 3:
            try:
                return tuple(float(v) for v in value)
            except (TypeError, ValueError):
                pass
        raise InputError(f"{name} must be three numbers, got {value!r}")
    if isinstance(sample, int) and "float" not in str(spec.type):
        if isinstance(value, int) and not isinstance(value, bool):
            return _not_negative(name, value)
        raise InputError(f"{name} must be an integer, got {value!r}")
    if "float" in str(spec.type):
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            return _not_negative(name, float(value))
        raise InputError(f"{name} must be a number, got {value!r}")
    if not isinstance(value, str):
        raise InputError(f"{name} must be text, got {value!r}")
    choices = spec.metadata["choices"]
    if choices and value not in choices:
        raise InputError(f"{name} must be one of {', '.join(choices)}, got {value!r}")
    return value


def _not_negative(name: str, value):
    """Every numeric parameter is a length, angle, count or fraction: finite and >= 0."""
    if not math.isfinite(value) or value < 0:
        raise InputError(f"{name} must be a finite number >= 0, got {value!r}")
    return value


def read_config_file(path: str | Path) -> dict[str, dict]:
    """Overrides `{section: {key: value}}` from a TOML config file, or from the `params` of a
    weldseam JSON path file (so a run can be reproduced from its output). Every key is checked
    against the defaults; errors name the file and `section.key`."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise InputError(f"{path}: config file not found") from None
    except (OSError, UnicodeDecodeError) as error:
        raise InputError(f"{path}: cannot read the config file ({error})") from None
    if path.suffix.lower() == ".json":
        try:
            data = json.loads(text)
        except json.JSONDecodeError as error:
            raise InputError(f"{path}: not valid JSON (line {error.lineno}: {error.msg})") from None
        data = data.get("params", data) if isinstance(data, dict) else data
    else:
        try:
            data = tomllib.loads(text)
        except tomllib.TOMLDecodeError as error:
            raise InputError(f"{path}: not valid TOML ({error})") from None
    if not isinstance(data, dict) or not all(isinstance(values, dict) for values in data.values()):
        raise InputError(f"{path}: expected [section] tables of key = value, e.g. [normals] radius_m = 0.008")
    try:
        with_overrides(PlanConfig(), data)
    except InputError as error:
        raise InputError(f"{path}: {error}") from None
    return data


def effective_config(config_file: str | Path | None, overrides: dict[str, dict]) -> PlanConfig:
    """Defaults, then the config file, then command-line overrides (the last one wins); the
    result must pass `check_relations`."""
    config = PlanConfig()
    if config_file is not None:
        config = with_overrides(config, read_config_file(config_file))
    config = with_overrides(config, overrides)
    check_relations(config)
    return config


# Sizes that divide space into cells or neighbourhoods: zero would mean infinitely many (and the
# weakest bend of a valley along its length: zero would take every mean above zero).
POSITIVE_KEYS = (
    "condition.voxel_m", "condition.working_voxel_m", "merge.icp_voxel_m", "merge.dedup_voxel_m",
    "smooth.radius_m", "normals.radius_m", "descriptor.radius_m", "segment.cluster_tolerance_m",
    "boundary.radius_m", "thinning.radius_m", "grid.leaf_m", "order.link_m", "section.half_width_m",
    "section.slab_m", "joints.face_radius_m", "extend.step_m", "resample.spacing_m",
    "segment.line_valley_min_crease_deg",
)
# Radii of neighbourhoods in the working cloud (points condition.working_voxel_m apart).
WORKING_RADIUS_KEYS = (
    "smooth.radius_m", "normals.radius_m", "descriptor.radius_m", "segment.cluster_tolerance_m",
    "boundary.radius_m", "thinning.radius_m",
)
# A neighbourhood of r / working voxel = k holds up to ~pi k^2 points of a surface (8: ~200), so
# memory grows with the number of working points (at most the input's), not with the
# parameters: 1.5 GB for the 189k-point v_butt sample at k = 8 (0.75 mm voxels), 0.17 GB at the
# defaults (k = 2.4). The automatic threshold's synthetic crease has (6 k)^2 points of pi k^2
# neighbours each: 0.5 million pairs at 8; the 0.0001 m working voxel that used 24 GB was k = 60.
MAX_RADIUS_VOXELS = 8.0
# valley_lines samples each point's line once per working voxel of its length.
MAX_LINE_VALLEY_VOXELS = 40
MIN_SPACING_M = 0.0001  # resample smooths with a (K, K) matrix of K = seam length / spacing knots


def check_relations(config: PlanConfig) -> None:
    """Refuse parameters that cannot work together, before any data is read: InputError naming
    the key. Sizes in POSITIVE_KEYS > 0; condition.working_voxel_m >= condition.voxel_m; each
    radius of WORKING_RADIUS_KEYS (in use) between 1 and MAX_RADIUS_VOXELS working voxels;
    order.link_m >= grid.leaf_m; direction.start_m with rule start-point only;
    segment.line_valley_length_m 0 or 2-MAX_LINE_VALLEY_VOXELS working voxels, with wide valleys;
    resample.spacing_m >= MIN_SPACING_M."""

    def value(key: str) -> float:
        section, name = key.split(".")
        return getattr(getattr(config, section), name)

    for key in POSITIVE_KEYS:
        if value(key) <= 0:
            raise InputError(f"{key} must be above 0, got {value(key)!r}")
    voxel, working = value("condition.voxel_m"), value("condition.working_voxel_m")
    if working < voxel:
        raise InputError(
            f"condition.working_voxel_m {working:g} is below condition.voxel_m {voxel:g}: the working cloud "
            "coarsens the fine one, so its voxel must be at least as large"
        )
    for key in WORKING_RADIUS_KEYS:
        if key == "smooth.radius_m" and not config.smooth.enabled:
            continue
        radius = value(key)
        if radius < working:
            raise InputError(
                f"{key} {radius:g} is below condition.working_voxel_m {working:g}: the neighbourhood would hold "
                "no neighbours"
            )
        if radius > MAX_RADIUS_VOXELS * working:
            raise InputError(
                f"{key} {radius:g} spans {radius / working:.3g} working voxels (condition.working_voxel_m "
                f"{working:g}), at most {MAX_RADIUS_VOXELS:g}: each neighbourhood would hold ~"
                f"{math.pi * (radius / working) ** 2:.0f} points and the memory grows with that; raise "
                f"condition.working_voxel_m to at least {radius / MAX_RADIUS_VOXELS:g} or lower {key}"
            )
    if value("order.link_m") < value("grid.leaf_m"):
        raise InputError(
            f"order.link_m {value('order.link_m'):g} is below grid.leaf_m {value('grid.leaf_m'):g}: "
            "neighbouring grid nodes could never be linked"
        )
    if (config.direction.rule == "start-point") != (config.direction.start_m is not None):
        raise InputError(
            "direction.start_m must be given with direction.rule start-point, and only then "
            f"(rule {config.direction.rule}, start_m {config.direction.start_m})"
        )
    line = value("segment.line_valley_length_m")
    if line and not 2 * working <= line <= MAX_LINE_VALLEY_VOXELS * working:
        raise InputError(
            f"segment.line_valley_length_m {line:g} must be 0 (off) or 2-{MAX_LINE_VALLEY_VOXELS} working voxels "
            f"({2 * working:g}-{MAX_LINE_VALLEY_VOXELS * working:g} m at condition.working_voxel_m {working:g}): a "
            "shorter line averages nothing, a longer one costs a lookup per point and voxel"
        )
    if line and not value("segment.wide_valley_radius_m"):
        raise InputError(
            "segment.line_valley_length_m needs segment.wide_valley_radius_m above 0: the valleys found along their "
            "length are traced with the wide ones (set both to 0 to seek neither)"
        )
    if value("resample.spacing_m") < MIN_SPACING_M:
        raise InputError(
            f"resample.spacing_m {value('resample.spacing_m'):g} is below {MIN_SPACING_M:g} m: finer than any "
            "torch needs, and the smoothing's memory grows with the square of the pose count"
        )


def config_to_toml(config: PlanConfig) -> str:
    """The whole config as TOML, each key with its help as a comment; unset optional keys are
    written commented out (TOML has no null), so the text reads back to the same config."""
    lines = ["# weldseam configuration: use with --config FILE; command-line options override it."]
    for section_field in fields(config):
        section = getattr(config, section_field.name)
        lines += ["", f"[{section_field.name}]"]
        for spec in fields(section):
            value = getattr(section, spec.name)
            lines.append(f"# {spec.metadata['help']}")
            lines.append(f"# {spec.name} =" if value is None else f"{spec.name} = {_toml_value(value)}")
    return "\n".join(lines) + "\n"


def _toml_value(value) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)):
        return repr(value)
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml_value(item) for item in value) + "]"
    return json.dumps(value)
