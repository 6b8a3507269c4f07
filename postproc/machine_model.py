"""The machine's own solids on its kinematic chain: components, poses, pair rules.

A machine file's ``[model]`` table (``postproc.machine_model_schema``) lists simple
solids - boxes, cylinders, cones (frusta) or STL meshes - each attached to one group
of the chain of a table-tilting machine (docs/machine-model.md):

* ``base``: the machine bed and the trunnion supports (fixed);
* ``X``, ``Y``, ``Z``: the carriages; the tool side is modelled as moving relative to
  the table (only relative motion matters), ``Z`` being the spindle head. Their frame
  origin is the holder's gauge line with all linear joints at zero; a component on
  ``X`` moves by (X, 0, 0), on ``Y`` by (X, Y, 0), on ``Z`` by (X, Y, Z);
* the tilt axis (``A`` or ``B``): the cradle; ``C``: the rotary table, the fixture and
  the part. Their frame is the workpiece frame W at A = C = 0 (origin at the C
  rotation point).

``group_poses`` gives each group's rotation and translation into the machine frame
for joint vectors, from the same formulas as the kinematics (``postproc.kinematics.
trt``): a point ``p`` on C is at ``r + o + Ru(s t) (Rz(s c) p - o)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from impeller_cam.errors import InputError
from impeller_cam.schema import suggest

if TYPE_CHECKING:
    from postproc.machine_model_schema import FixtureTable, ModelTable

__all__ = [
    "JOB_SOLIDS",
    "TOOL_SIDE",
    "MachineModel",
    "PairRule",
    "Solid",
    "fixture_solids",
    "group_poses",
    "model_from_table",
    "rotation",
]

#: Solids the verifier adds to the machine's: tool, holder, part, fixture.
JOB_SOLIDS = ("tool", "holder", "part", "mandrel_nut", "riser", "chuck", "jaw_1", "jaw_2",
              "jaw_3")
#: Groups that carry the tool (relative motion: translations only), in chain order.
TOOL_SIDE = ("X", "Y", "Z")


def rotation(angle: NDArray[np.float64], about: int) -> NDArray[np.float64]:
    """Right-handed rotation matrices ``(n, 3, 3)`` by ``angle`` (n,) rad about X/Y/Z."""
    angle = np.asarray(angle, dtype=np.float64).reshape(-1)
    cos, sin = np.cos(angle), np.sin(angle)
    out = np.zeros((len(angle), 3, 3))
    i, j = {0: (1, 2), 1: (2, 0), 2: (0, 1)}[about]
    out[:, about, about] = 1.0
    out[:, i, i] = cos
    out[:, i, j] = -sin
    out[:, j, i] = sin
    out[:, j, j] = cos
    return out


@dataclass(frozen=True)
class Solid:
    """One component as a triangle mesh in its group's frame.

    Attributes
    ----------
    name : str
        Unique name (``"part"``, ``"tool"``, ``"holder"`` and the fixture's names are
        added by the verifier).
    group : str
        ``"base"``, ``"X"``, ``"Y"``, ``"Z"``, the tilt axis letter or ``"C"``.
    kind : str
        ``"box"``, ``"cylinder"``, ``"convex"`` (a cone, a turned box) or ``"stl"``.
    vertices : (v, 3) float64
        Mesh vertices in the group frame, mm.
    faces : (f, 3) int64
        Triangles.
    box : tuple or None
        ``(size (3,), centre (3,))`` of an axis-aligned box (exact fcl box).
    cylinder : tuple or None
        ``(radius, length, rotation (3, 3), centre (3,))`` (exact fcl cylinder).
    pieces : tuple of (p, 3) float64
        Points whose convex hulls, together, hold the solid (distances are taken to
        them instead of the mesh: a non-convex part as a few convex pieces).
    """

    name: str
    group: str
    kind: str
    vertices: NDArray[np.float64]
    faces: NDArray[np.int64]
    box: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None
    cylinder: tuple[float, float, NDArray[np.float64], NDArray[np.float64]] | None = None
    pieces: tuple[NDArray[np.float64], ...] = ()

    @property
    def centre(self) -> NDArray[np.float64]:
        """Centre of the bounding sphere, group frame, mm (3,)."""
        lo, hi = self.vertices.min(axis=0), self.vertices.max(axis=0)
        return 0.5 * (lo + hi)

    @property
    def radius(self) -> float:
        """Radius of a sphere about ``centre`` holding the solid, mm."""
        return float(np.linalg.norm(self.vertices - self.centre, axis=1).max())


def _along(axis: str) -> NDArray[np.float64]:
    """Rotation taking local +Z onto the axis ``"x"``, ``"y"`` or ``"z"``."""
    if axis == "x":
        return np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])
    if axis == "y":
        return np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
    return np.eye(3)


def frustum_mesh(r0: float, r1: float, length: float, sections: int = 32
                 ) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Closed frustum ``(vertices, faces)`` along +Z, centred, radii ``r0`` (bottom) and
    ``r1`` (top) as circumradii of ``sections``-gons scaled to contain the true solid."""
    scale = 1.0 / math.cos(math.pi / sections)
    theta = np.linspace(0.0, 2.0 * math.pi, sections, endpoint=False)
    ring = np.stack([np.cos(theta), np.sin(theta)], axis=1) * scale
    bottom = np.column_stack([r0 * ring, np.full(sections, -0.5 * length)])
    top = np.column_stack([r1 * ring, np.full(sections, 0.5 * length)])
    vertices = np.vstack([bottom, top, [[0, 0, -0.5 * length], [0, 0, 0.5 * length]]])
    faces = []
    lo_c, hi_c = 2 * sections, 2 * sections + 1
    for i in range(sections):
        j = (i + 1) % sections
        faces += [[i, j, sections + j], [i, sections + j, sections + i],
                  [lo_c, j, i], [hi_c, sections + i, sections + j]]
    return vertices, np.asarray(faces, dtype=np.int64)


def box_solid(name: str, group: str, size: Any, centre: Any) -> Solid:
    """An axis-aligned box of edge lengths ``size`` (3,) centred at ``centre`` (3,), mm."""
    size = np.asarray(size, dtype=np.float64)
    centre = np.asarray(centre, dtype=np.float64)
    corners = np.array([[i, j, k] for i in (-0.5, 0.5) for j in (-0.5, 0.5)
                        for k in (-0.5, 0.5)]) * size + centre
    faces = np.array([[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
                      [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]])
    return Solid(name, group, "box", corners, faces, box=(size, centre))


def round_solid(name: str, group: str, r0: float, r1: float, length: float,
                along: str, centre: Any) -> Solid:
    """A cylinder (``r0 == r1``) or a frustum along ``along``, centred at ``centre``."""
    turn = _along(along)
    centre = np.asarray(centre, dtype=np.float64)
    vertices, faces = frustum_mesh(r0, r1, length)
    vertices = vertices @ turn.T + centre
    if r0 == r1:
        return Solid(name, group, "cylinder", vertices, faces,
                     cylinder=(float(r0), float(length), turn, centre))
    return Solid(name, group, "convex", vertices, faces)


@dataclass(frozen=True)
class PairRule:
    """A ``[[model.pair]]`` rule: a clearance, or a pair left out and why."""

    clearance: float | None
    check: bool
    reason: str


@dataclass(frozen=True)
class MachineModel:
    """The machine's components and pair rules (from ``[model]``).

    Attributes
    ----------
    components : tuple of Solid
        The machine's own solids (the verifier adds tool, holder, part, fixture).
    clearance : float
        Default smallest distance of a checked pair, mm.
    step : float
        Largest motion of any machine point between two checked poses, mm.
    fixture : FixtureTable or None
        What holds the blank (placed on the part by ``fixture_solids``).
    rules : mapping of frozenset({a, b}) -> PairRule
    tilt : str
        The tilt axis letter of the kinematics (``"A"`` or ``"B"``).
    """

    components: tuple[Solid, ...]
    clearance: float = 2.0
    step: float = 1.0
    fixture: FixtureTable | None = None
    rules: dict[frozenset[str], PairRule] = field(default_factory=dict)
    tilt: str = "A"

    def pair_rule(self, a: Solid, b: Solid) -> tuple[float | None, str]:
        """Clearance of a pair (mm), or ``None`` and the reason it is left out."""
        rule = self.rules.get(frozenset((a.name, b.name)))
        if rule is not None and not rule.check:
            return None, rule.reason
        if a.group == b.group:
            return None, "one rigid body"
        if a.group in TOOL_SIDE and b.group in TOOL_SIDE:
            return None, "carriages slide on each other's guides"
        names = {a.name, b.name}
        if "part" in names and names & {"tool", "holder"}:
            return None, "the dexel sweep checks cutter, shank and holder against the stock"
        if rule is not None and rule.clearance is not None:
            return rule.clearance, ""
        return self.clearance, ""


def fixture_solids(fixture: FixtureTable, part_bottom: float, part_top: float,
                   part_radius: float, group: str = "C") -> list[Solid]:
    """The fixture's solids in W (group C), mm.

    Parameters
    ----------
    fixture : FixtureTable
    part_bottom, part_top : float
        Heights of the part's bottom and top faces in W, mm (the riser or chuck body
        stands under the bottom face, the mandrel's nut on the top face).
    part_radius : float
        Radius of the part's rim at its bottom face (where chuck jaws grip), mm.
    """
    solids: list[Solid] = []
    h = fixture.height
    if fixture.kind == "mandrel":
        r_nut = 0.5 * fixture.nut_diameter
        solids.append(round_solid("mandrel_nut", group, r_nut, r_nut, fixture.nut_height, "z",
                                  (0, 0, part_top + 0.5 * fixture.nut_height)))
        if h > 0:
            r = 0.5 * fixture.riser_diameter
            solids.append(round_solid("riser", group, r, r, h, "z",
                                      (0, 0, part_bottom - 0.5 * h)))
        return solids
    r = 0.5 * fixture.diameter
    solids.append(round_solid("chuck", group, r, r, h, "z", (0, 0, part_bottom - 0.5 * h)))
    depth = max(0.15 * fixture.diameter, 10.0)
    for k in range(3):
        angle = 2.0 * math.pi * k / 3.0 + 0.5 * math.pi
        jaw = box_solid(f"jaw_{k + 1}", group, (depth, fixture.jaw_width, fixture.jaw_height),
                        (0.0, 0.0, 0.0))
        turn = rotation(np.array([angle]), 2)[0]
        middle = part_radius + 0.5 * depth
        centre = np.array([middle * math.cos(angle), middle * math.sin(angle),
                           part_bottom + 0.5 * fixture.jaw_height])
        solids.append(Solid(jaw.name, group, "convex", jaw.vertices @ turn.T + centre,
                            jaw.faces))
    return solids


def group_poses(
    kins: Any, joints: NDArray[np.float64], gauge: float, tilt: str
) -> dict[str, tuple[NDArray[np.float64], NDArray[np.float64]]]:
    """Rotation ``(n, 3, 3)`` and translation ``(n, 3)`` of every group, machine frame.

    Parameters
    ----------
    kins : TableTiltingRotary
        The kinematics (``rot_point``, ``offset``, ``tilt_about``, ``sign``).
    joints : (n, 5) float64
        X, Y, Z (mm), tilt, C (rad).
    gauge : float
        Height of the holder's gauge line above the tool tip, mm.
    tilt : str
        The tilt axis letter.

    Returns
    -------
    dict
        group -> (R, t): a point ``p`` of the group frame is at ``R p + t``.
    """
    joints = np.asarray(joints, dtype=np.float64).reshape(-1, 5)
    n = len(joints)
    eye = np.broadcast_to(np.eye(3), (n, 3, 3))
    r, o, s = kins.rot_point, kins.offset, kins.sign
    tilted = rotation(s * joints[:, 3], kins.tilt_about)
    pivot = r + o - tilted @ o
    poses: dict[str, tuple[NDArray[np.float64], NDArray[np.float64]]] = {
        "base": (eye, np.broadcast_to(r, (n, 3))),
        tilt: (tilted, pivot),
        "C": (tilted @ rotation(s * joints[:, 4], 2), pivot),
    }
    for k, name in enumerate(TOOL_SIDE):
        moved = np.zeros((n, 3))
        moved[:, : k + 1] = joints[:, : k + 1]
        moved[:, 2] += gauge
        poses[name] = (eye, moved)
    return poses


# --------------------------------------------------------------------------- loading
def _stl(file: Path | None, where: str, name: str) -> tuple[NDArray, NDArray]:
    import trimesh

    path = Path(name) if file is None else file.parent / name
    try:
        mesh = trimesh.load(path, force="mesh", file_type="stl")
    except Exception as error:  # noqa: BLE001 - any reader failure is bad input
        raise InputError(f"cannot read the STL {str(path)!r}: {error}", file=file,
                         field=f"{where}.file", value=name,
                         accepted="a readable STL file next to the machine file") from None
    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
        raise InputError(f"the STL {str(path)!r} holds no triangle", file=file,
                         field=f"{where}.file", value=name, accepted="a triangle mesh")
    return np.asarray(mesh.vertices, np.float64), np.asarray(mesh.faces, np.int64)


def model_from_table(
    table: ModelTable, joint_names: tuple[str, ...], file: Path | None = None
) -> MachineModel:
    """Check a validated ``[model]`` against the kinematics and read its STL files.

    Parameters
    ----------
    table : ModelTable
    joint_names : tuple of str
        The kinematics' joints, e.g. ``("X", "Y", "Z", "A", "C")``.
    file : Path, optional
        The machine file (named in errors; STL paths are relative to it).

    Raises
    ------
    InputError
        A component on an axis the kinematics lacks, a duplicate name, an unreadable
        STL, a pair naming an unknown component.
    """
    tilt = next((n for n in joint_names[3:] if n != "C"), "A")
    accepted = ["base", *joint_names]
    solids: list[Solid] = []
    for i, entry in enumerate(table.component):
        where = f"model.component[{i}] '{entry.name}'"
        if entry.axis not in accepted:
            near = suggest(entry.axis, accepted)
            hint = f"; did you mean {near!r}?" if near else ""
            raise InputError(f"the kinematics has no axis {entry.axis!r}{hint}", file=file,
                             field=f"{where}.axis", value=entry.axis,
                             accepted=", ".join(accepted))
        if any(s.name == entry.name for s in solids):
            raise InputError("duplicate component name", file=file, field=f"{where}.name",
                             value=entry.name, accepted="a name used once")
        if entry.shape == "box":
            solids.append(box_solid(entry.name, entry.axis, entry.size, entry.at))
        elif entry.shape in ("cylinder", "cone"):
            assert entry.radius is not None and entry.length is not None
            top = entry.radius if entry.shape == "cylinder" else entry.top_radius
            solids.append(round_solid(entry.name, entry.axis, entry.radius, float(top or 0.0),
                                      entry.length, entry.along, entry.at))
        else:
            assert entry.file is not None
            vertices, faces = _stl(file, where, entry.file)
            solids.append(Solid(entry.name, entry.axis, "stl",
                                vertices + np.asarray(entry.at), faces))
    names = {s.name for s in solids} | set(JOB_SOLIDS)
    rules: dict[frozenset[str], PairRule] = {}
    for i, pair in enumerate(table.pair):
        for key in ("a", "b"):
            value = getattr(pair, key)
            if value not in names:
                near = suggest(value, sorted(names))
                hint = f"; did you mean {near!r}?" if near else ""
                raise InputError(f"no component {value!r}{hint}", file=file,
                                 field=f"model.pair[{i}].{key}", value=value,
                                 accepted=", ".join(sorted(names)))
        rules[frozenset((pair.a, pair.b))] = PairRule(pair.clearance, pair.check, pair.reason)
    return MachineModel(tuple(solids), table.clearance, table.step, table.fixture, rules, tilt)
