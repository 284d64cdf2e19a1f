"""Cross-sections of the fine surface: the profile across a seam, and the joint fitted to it.

At a point c of a seam line, with travel direction t and approximate torch axis a (into the
work), the fine points in a thin slab across the seam are projected onto the section plane:
u = lateral offset along l = t x a, w = height out of the work (-a). The profile w(u) is
fitted with the joint models (weldseam.pipeline.joints); a fit is brought back to 3D.
"""

from __future__ import annotations

from collections.abc import Collection
from dataclasses import dataclass, field
from enum import IntFlag

import numpy as np

from weldseam.config import JointsConfig, PlanConfig
from weldseam.geometry import unit
from weldseam.pipeline.joints import JointGeometry, JointKind, ProfileFit, akin, fit_profile, recentred
from weldseam.pipeline.joints.profile import NO_OPENINGS
from weldseam.pipeline.occlusion import ViewBuffer
from weldseam.pipeline.one_face import one_face_corner
from weldseam.pipeline.one_face_ridge import one_face_ridge
from weldseam.pipeline.parallel import map_shared

# A fit of a kind that assumes the joint in the middle of its window (joints.recentred) made
# this far from its centre, or with its torch axis this far from the frame's, is fitted again
# in its own frame.
RECENTRE_M = 0.003
RECENTRE_COS = float(np.cos(np.radians(8.0)))
# Where no joint fits a section of a seam being followed, these of its kinds are sought again in a
# window this share as wide (FineSurface._narrow). In a narrow window a V-groove's wall and bottom
# make a lap's step: nested.py drops what lies inside a groove's opening.
NARROW_SHARE = 0.5
NARROW_KINDS = frozenset({JointKind.FILLET, JointKind.LAP, JointKind.OUTSIDE_CORNER})
# A gap's middles lie one per pixel row or column crossing it (~1 mm apart along it): those within
# this of a section's plane are the openings it shows there.
OPENING_ALONG_M = 0.003


@dataclass(frozen=True)
class SectionParams:
    """The section window: its reach from the seam (m), its thickness along the seam (m) and
    `min_points`, what a fully sampled flat section holds (a slab holding fewer is taken twice
    as thick: sparse, grazing data); and the joint models' parameters."""

    half_width_m: float
    slab_m: float
    min_points: int
    joints: JointsConfig


def section_params(config: PlanConfig) -> SectionParams:
    """The section parameters of a run: its section window, its joint models' parameters, and
    `min_points` = (2 half_width / voxel) x (slab / voxel) at the fine voxel."""
    window = config.section
    return SectionParams(
        half_width_m=window.half_width_m, slab_m=window.slab_m,
        min_points=round(2 * window.half_width_m * window.slab_m / config.condition.voxel_m**2), joints=config.joints,
    )


class PointFlag(IntFlag):
    """What a seam point rests on besides a full fit of its section: one face of a corner unseen
    (one_face, one_face_ridge), maybe placed from an occluder's outline; a groove bridged over a
    dropout from the edges still seen (bridge); a stretch interpolated across a hole in the scan
    (holes)."""

    ONE_FACE = 1
    BRIDGED = 2
    INTERPOLATED = 4
    ROUGH = 8  # the model's outline lies ROUGH_FIT_M or more from the section's points (median)
    # One face unseen, the other placed from an occluder's outline that does not run along the seam
    # (one_face): a standing pipe near its silhouette, or past it the edge of its shadow. Such a
    # corner is no seam by itself; an extension takes it where the curve of full fits leads.
    OUTLINE = 16


# How sure a pose is, by the least sure of what its point rests on (1: a full fit of its section).
POSE_CONFIDENCE = {PointFlag.ROUGH: 0.6, PointFlag.ONE_FACE: 0.7, PointFlag.BRIDGED: 0.5,
                   PointFlag.INTERPOLATED: 0.3}  # fmt: skip
ROUGH_FIT_M = 0.0008


def pose_confidence(flags: np.ndarray) -> np.ndarray:
    """(K,) confidence 0..1 of poses with PointFlag bits `flags` (K,): the least of POSE_CONFIDENCE
    over the bits set, 1 with none."""
    confidence = np.ones(len(flags))
    for flag, value in POSE_CONFIDENCE.items():
        confidence = np.where(flags & flag, np.minimum(confidence, value), confidence)
    return confidence


@dataclass(frozen=True)
class SectionFit:
    """One cross-section's result in 3D: the joint kind (None: no fit), the seam point (3,) (m),
    the unit torch axis (3,) into the work, the measured geometry, whether it was bridged over a
    dropout (weldseam.pipeline.bridge) and, with no fit, why; flags: PointFlag bits."""

    kind: JointKind | None
    point_m: np.ndarray
    torch_axis: np.ndarray
    geometry: JointGeometry = field(default_factory=JointGeometry)
    bridged: bool = False
    reason: str = ""
    flags: int = 0

    @property
    def half_opening_m(self) -> float:
        """Half the width of a groove's opening (m); 0 for a joint without one."""
        return 0.0 if self.geometry.opening_m is None else self.geometry.opening_m / 2


@dataclass(frozen=True)
class Profile:
    """The points of one section: u lateral, w height out of the work, along the offset along the
    seam (m), each (N,); the section's frame: centre, travel, torch axis, lateral (3,); and the u
    (m) of the openings the sensor's image shows at the section (FineSurface.openings)."""

    u: np.ndarray
    w: np.ndarray
    along: np.ndarray
    centre: np.ndarray
    axis: np.ndarray
    lateral: np.ndarray
    openings_u: np.ndarray = field(default_factory=lambda: NO_OPENINGS)

    def to_3d(self, fit: ProfileFit | None, bridged: bool = False, reason: str = "") -> SectionFit:
        """The SectionFit of a profile fit (None: no fit) in this section's frame."""
        if fit is None:
            return SectionFit(None, self.centre, self.axis, reason=reason)
        point = self.centre + fit.u * self.lateral - fit.w * self.axis
        torch_axis = unit(fit.axis_u * self.lateral - fit.axis_w * self.axis)
        flags = ((PointFlag.ONE_FACE if fit.geometry.faces_seen == 1 else 0) | (PointFlag.BRIDGED if bridged else 0)
                 | (PointFlag.OUTLINE if fit.geometry.outline_wall else 0)
                 | (PointFlag.ROUGH if fit.residual_m >= ROUGH_FIT_M else 0))  # fmt: skip
        return SectionFit(fit.kind, point, torch_axis, fit.geometry, bridged, flags=int(flags))


@dataclass(frozen=True, eq=False)
class FineSurface:
    """The fine cloud (N, 3) with its search tree (a cKDTree over it) and the section parameters:
    what every cross-section reads; the single camera's view (occlusion.ViewBuffer) and a cKDTree
    over the middles of the thin gaps its image shows (gaps.gap_midpoints), or None. While a
    parallel.worker_process holds this object, fit_many shares its batches with the worker."""

    points: np.ndarray
    tree: object
    params: SectionParams
    view: ViewBuffer | None = None
    openings: object = None

    def sight(self, profile: Profile, u: float, w: float, along: float = 0.0) -> tuple[float, float, float] | None:
        """(u, w, along) of the wall top the camera sees past the profile point (u, w) moved `along`
        the travel (m): the nearest scan point on the line of sight through it, at least a fillet
        leg nearer to the camera, in the section's frame (along: its offset along the travel,
        axis x lateral). None without a single camera (view) or when nothing is nearer."""
        if self.view is None:
            return None
        travel = np.cross(profile.axis, profile.lateral)
        point = profile.centre + u * profile.lateral - w * profile.axis + along * travel
        index = self.view.nearer_than(point[None], self.params.joints.fillet_min_leg_m)[0]
        if index < 0:
            return None
        offset = self.view.points[index] - profile.centre
        return float(offset @ profile.lateral), float(-(offset @ profile.axis)), float(offset @ travel)

    def profile(self, centre, travel, axis, lateral) -> Profile:
        """The section at `centre` across unit `travel`, in the frame (axis, lateral) given.

        A slab with fewer than `min_points` is taken twice as thick when the thicker slab's points
        lie evenly on both sides of the section plane (not so just past a part's end)."""
        members = self.tree.query_ball_point(centre, self.params.half_width_m, return_sorted=False)
        # take converts the list of indices at a third of the cost of indexing with it.
        offsets = self.points.take(members, axis=0) - centre
        along, u, w = offsets @ travel, offsets @ lateral, -(offsets @ axis)
        reach = self.params.half_width_m
        inside = (np.abs(u) <= reach) & (np.abs(w) <= reach)
        keep = inside & (np.abs(along) <= self.params.slab_m / 2)
        # Grazing or sparse data: a slab twice as thick (sagitta < 0.1 mm at r 50 mm).
        if np.count_nonzero(keep) < self.params.min_points:
            thick = inside & (np.abs(along) <= self.params.slab_m)
            if balanced(along[thick]):
                keep = thick
        openings_u = self._openings_u(centre, travel, axis, lateral)
        return Profile(u[keep], w[keep], along[keep], centre, axis, lateral, openings_u)

    def _openings_u(self, centre, travel, axis, lateral) -> np.ndarray:
        """The u of the gap middles within OPENING_ALONG_M of the section plane and the window."""
        if self.openings is None:
            return NO_OPENINGS
        members = self.openings.query_ball_point(centre, self.params.half_width_m, return_sorted=True)
        offsets = self.openings.data[members] - centre
        near = (np.abs(offsets @ travel) <= OPENING_ALONG_M) & (np.abs(offsets @ axis) <= self.params.half_width_m)
        return offsets[near] @ lateral

    def fit(self, centre, travel, axis, kinds: Collection[JointKind] | None = None) -> SectionFit:
        """The joint in the section at `centre` across `travel`, with `axis` made perpendicular
        to it (section_frame); `kinds`: only these are sought (None: any)."""
        return self.fit_profile(self.profile(centre, travel, *section_frame(travel, axis)), kinds)

    def fit_profile(self, profile: Profile, kinds: Collection[JointKind] | None = None) -> SectionFit:
        """fit_profile of a section's points, in 3D; where no model fits, a fillet, lap or outside
        corner sought in the window half as wide (_narrow), then, with a single camera, a corner of
        a sought kind with one face unseen (_one_face)."""
        toward = self.toward(profile)
        found = fit_profile(profile.u, profile.w, self.params.joints, kinds, profile.openings_u, toward)
        if isinstance(found, ProfileFit):
            return profile.to_3d(found)
        narrow = self._narrow(profile, kinds, toward)
        if narrow is not None:
            return profile.to_3d(narrow)
        corner = self._one_face(profile, kinds, toward) if toward is not None else None
        if corner is not None:
            return profile.to_3d(corner)
        return profile.to_3d(None, reason=found.reason)

    def toward(self, profile: Profile) -> tuple[float, float] | None:
        """The (u, w) unit direction from the section's centre toward the single camera, in the
        section's plane (None without one)."""
        if self.view is None:
            return None
        toward = unit(self.view.camera_m - profile.centre)
        return float(toward @ profile.lateral), float(-(toward @ profile.axis))

    def _narrow(self, profile: Profile, kinds: Collection[JointKind] | None,
                toward: tuple[float, float] | None) -> ProfileFit | None:
        """The fit of the sought `kinds` of NARROW_KINDS in the window NARROW_SHARE as wide (None
        when none is sought, or none fits there): another part's surfaces within the window (a
        clamp, a flange's far part, the web of a joint nearby) spoil a face's line, and a corner's
        own faces reach far enough from it to fit in the narrower one. Only where a seam of those
        kinds is followed (the probes seek every kind, in the full window)."""
        sought = [] if kinds is None else [kind for kind in kinds if kind in NARROW_KINDS]
        if not sought:
            return None
        reach = NARROW_SHARE * self.params.half_width_m
        near = (np.abs(profile.u) <= reach) & (np.abs(profile.w) <= reach)
        found = fit_profile(profile.u[near], profile.w[near], self.params.joints, sought, toward=toward)
        return found if isinstance(found, ProfileFit) else None

    def _one_face(self, profile: Profile, kinds: Collection[JointKind] | None,
                  toward_uw: tuple[float, float]) -> ProfileFit | None:
        """A corner of the sought `kinds` with one face unseen: an inside corner (one_face), else an
        outside corner (one_face_ridge); None where neither is sought or fits. `toward_uw`: the
        direction to the camera (toward)."""
        order = np.argsort(profile.u, kind="stable")
        u, w = profile.u[order], profile.w[order]
        corner = None
        if kinds is None or JointKind.FILLET in kinds:
            corner = one_face_corner(u, w, toward_uw, lambda u, w, along=0.0: self.sight(profile, u, w, along),
                                     self.params.joints, self.params.half_width_m)  # fmt: skip
        if corner is None and (kinds is None or JointKind.OUTSIDE_CORNER in kinds):
            corner = one_face_ridge(u, w, toward_uw, self.params.joints, self.params.half_width_m)
        return corner

    def fit_many(self, centres, travel, axes, lateral, kinds: Collection[JointKind] | None = None) -> list[SectionFit]:
        """One fit per section (centres, travel, axes, lateral: (K, 3) each, a frame per row, as
        section_frames gives them), half of them on the worker process if one holds this surface.

        A fit of a kind that assumes the joint in the middle of its window, made far from its
        centre or with a torch axis far from the frame's (a coarse line that runs along one
        groove wall), is fitted again in the frame it found: centred on its seam point, across
        the same travel, with its torch axis, seeking its kind and kin alone (joints.akin: a fit
        of another kind there would not replace it). The joint then sits in the middle of the
        window with its surface level, as the fit assumes."""
        fits = self._fit_all(centres, travel, axes, lateral, kinds)
        moved = [
            k for k, fit in enumerate(fits)
            if fit.kind is not None and recentred(fit.kind)
            and (np.linalg.norm(fit.point_m - centres[k]) > RECENTRE_M or fit.torch_axis @ axes[k] < RECENTRE_COS)
        ]
        for kind in sorted({fits[k].kind for k in moved}, key=lambda kind: kind.value):
            again_at = [k for k in moved if fits[k].kind == kind]
            sought = akin({kind}) if kinds is None else akin({kind}) & frozenset(kinds)
            again_axes, again_lateral = zip(*(section_frame(travel[k], fits[k].torch_axis) for k in again_at))
            again = self._fit_all(
                np.array([fits[k].point_m for k in again_at]), travel[again_at], np.array(again_axes),
                np.array(again_lateral), sought,
            )
            for k, fit in zip(again_at, again):
                if fit.kind == kind:
                    fits[k] = fit
        return fits

    def _fit_all(self, centres, travel, axes, lateral, kinds) -> list[SectionFit]:
        kinds = None if kinds is None else frozenset(kinds)
        return map_shared(_fit_framed, (self,), [(*frame, kinds) for frame in zip(centres, travel, axes, lateral)])


def _fit_framed(surface: FineSurface, item) -> SectionFit:
    """The fit of one (centre, travel, axis, lateral, kinds)."""
    centre, travel, axis, lateral, kinds = item
    return surface.fit_profile(surface.profile(centre, travel, axis, lateral), kinds)


def section_frames(centres: np.ndarray, axes: np.ndarray, closed: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Along a seam line (K, 3): travel t (K, 3), torch axis a made perpendicular to t, and
    lateral l = t x a."""
    if closed:
        travel = np.roll(centres, -1, axis=0) - np.roll(centres, 1, axis=0)
    else:
        travel = np.gradient(centres, axis=0) if len(centres) > 1 else np.zeros_like(centres)
    travel = unit(travel)
    axes = unit(axes - np.sum(axes * travel, axis=1, keepdims=True) * travel)
    return travel, axes, np.cross(travel, axes)


def section_frame(travel: np.ndarray, axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The torch axis made perpendicular to `travel`, and the lateral direction travel x axis."""
    axis = unit(axis - (axis @ travel) * travel)
    return axis, np.cross(travel, axis)


def balanced(along: np.ndarray) -> bool:
    """Whether 35-65 % of the points lie ahead of the section plane."""
    return 0.35 * len(along) <= np.count_nonzero(along > 0) <= 0.65 * len(along)
