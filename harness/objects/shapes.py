"""Procedural, watertight meshes for the default object set (``harness objects build``).

No boolean engine is needed: solids of revolution are built from a profile, the mug's handle is a
swept tube stitched into holes cut in the cup's outer wall, the banana is a tapered swept tube.
Every builder returns a watertight, consistently wound ``trimesh.Trimesh`` with outward normals,
in metres, z up, centred on its bounding-box centre (the frame the example objects use).
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import trimesh


def _finish(vertices: np.ndarray, faces: np.ndarray, name: str) -> trimesh.Trimesh:
    """Merge, orient outwards, centre on the bounding box, and check the result is a solid."""
    mesh = trimesh.Trimesh(vertices=vertices, faces=faces, process=True)
    mesh.remove_unreferenced_vertices()
    if mesh.volume < 0:
        mesh.invert()
    mesh.apply_translation(-mesh.bounds.mean(axis=0))
    if not (mesh.is_watertight and mesh.is_winding_consistent and mesh.volume > 0):
        raise RuntimeError(f"shape {name!r} is not a closed, consistently wound solid")
    return mesh


def box(extents: tuple[float, float, float]) -> trimesh.Trimesh:
    """An axis-aligned box with the given full side lengths (m)."""
    mesh = trimesh.creation.box(extents=extents)
    return _finish(mesh.vertices, mesh.faces, "box")


def ball(radius: float, subdivisions: int = 3) -> trimesh.Trimesh:
    """An icosphere."""
    mesh = trimesh.creation.icosphere(subdivisions=subdivisions, radius=radius)
    return _finish(mesh.vertices, mesh.faces, "ball")


class Revolution:
    """A surface of revolution about z from a profile of (r, z) points.

    The profile runs from a point on the axis (r = 0) to another point on the axis; points with
    r = 0 become single pole vertices, the others rings of ``sections`` vertices. ``ring_start[k]``
    is the index of the first vertex of profile point k's ring (vertex ``ring_start[k] + j`` sits
    at angle ``2 pi j / sections``), which lets callers cut holes in a known grid cell.
    """

    def __init__(self, profile: np.ndarray, sections: int) -> None:
        profile = np.asarray(profile, dtype=float)
        if profile[0, 0] != 0 or profile[-1, 0] != 0 or np.any(profile[1:-1, 0] <= 0):
            raise ValueError("profile must start and end on the axis and stay off it between")
        self.sections = sections
        self.profile = profile
        angles = 2 * np.pi * np.arange(sections) / sections
        vertices: list[np.ndarray] = []
        self.ring_start: list[int] = []
        count = 0
        for r, z in profile:
            self.ring_start.append(count)
            if r == 0:
                vertices.append(np.array([[0.0, 0.0, z]]))
                count += 1
            else:
                ring = np.column_stack(
                    [r * np.cos(angles), r * np.sin(angles), np.full(sections, z)]
                )
                vertices.append(ring)
                count += sections
        self.vertices = np.vstack(vertices)
        faces: list[list[int | np.integer]] = []
        j = np.arange(sections)
        jn = (j + 1) % sections
        self.quad_faces: dict[tuple[int, int], tuple[int, int]] = {}
        for k in range(len(profile) - 1):
            a, b = self.ring_start[k], self.ring_start[k + 1]
            if profile[k, 0] == 0:  # pole to ring: a fan
                faces.extend([a, b + jj, b + jn_] for jj, jn_ in zip(j, jn, strict=True))
            elif profile[k + 1, 0] == 0:  # ring to pole
                faces.extend([a + jj, b, a + jn_] for jj, jn_ in zip(j, jn, strict=True))
            else:
                for jj, jn_ in zip(j, jn, strict=True):
                    self.quad_faces[(k, int(jj))] = (len(faces), len(faces) + 1)
                    faces.append([a + jj, b + jj, b + jn_])
                    faces.append([a + jj, b + jn_, a + jn_])
        self.faces = np.asarray(faces, dtype=np.int64)

    def vertex(self, k: int, j: int) -> int:
        """Index of the ring vertex of profile point k at angular step j."""
        return self.ring_start[k] + j % self.sections


def revolve(profile: list[tuple[float, float]], sections: int = 64, name: str = "revolve"):
    """A closed solid of revolution from an (r, z) profile that starts and ends on the axis."""
    rev = Revolution(np.asarray(profile), sections)
    return _finish(rev.vertices, rev.faces, name)


def can(radius: float = 0.033, height: float = 0.115, sections: int = 64) -> trimesh.Trimesh:
    """A drinks can: a cylinder with chamfered top and bottom edges."""
    c = 0.004
    profile = [
        (0.0, 0.0),
        (radius - c, 0.0),
        (radius, c),
        (radius, height - 1.5 * c),
        (radius - c, height),
        (0.0, height),
    ]
    return revolve(profile, sections, "can")


def bottle(
    body_radius: float = 0.03,
    neck_radius: float = 0.013,
    height: float = 0.205,
    sections: int = 64,
) -> trimesh.Trimesh:
    """A bottle: cylindrical body, rounded shoulder, neck and a slightly wider cap."""
    body_top = 0.62 * height
    shoulder_top = 0.82 * height
    cap_radius = neck_radius + 0.002
    profile = [(0.0, 0.0), (body_radius - 0.003, 0.0), (body_radius, 0.003)]
    profile += [(body_radius, z) for z in np.linspace(0.02, body_top, 6)]
    for t in np.linspace(0.0, 1.0, 9)[1:]:  # cosine shoulder from body to neck
        r = neck_radius + (body_radius - neck_radius) * 0.5 * (1 + np.cos(np.pi * t))
        profile.append((r, body_top + t * (shoulder_top - body_top)))
    cap_bottom = height - 0.018
    profile += [(neck_radius, cap_bottom), (cap_radius, cap_bottom), (cap_radius, height - 0.002)]
    profile += [(cap_radius - 0.002, height), (0.0, height)]
    return revolve(profile, sections, "bottle")


def plate(radius: float = 0.1, height: float = 0.022, thickness: float = 0.003, sections: int = 72):
    """A plate: a flat centre with a sloped rim, shell ``thickness`` thick."""
    flat = 0.6 * radius
    profile = [
        (0.0, 0.0),
        (flat, 0.0),
        (radius, height - thickness),  # underside of the rim
        (radius, height),  # lip
        (radius - thickness, height),
        (flat + 0.5 * thickness, thickness),  # top surface of the rim, then the flat centre
        (0.0, thickness),
    ]
    return revolve(profile, sections, "plate")


def mug(
    radius: float = 0.04,
    height: float = 0.09,
    wall: float = 0.004,
    handle_reach: float = 0.028,
    sections: int = 48,
) -> trimesh.Trimesh:
    """A mug: a hollow cylinder with a bottom and a D-shaped handle, one closed genus-1 solid.

    The handle is a tube whose end loops are the boundaries of two 2 x 2 cell holes cut in the
    outer wall, so the result is watertight without a boolean union.
    """
    row = 0.005  # vertical spacing of the outer-wall rings (the handle's thickness is 2 rows)
    outer_z = np.arange(0.0, height + 1e-9, row)
    outer_z[-1] = height
    profile = [(0.0, 0.0)] + [(radius, z) for z in outer_z]
    inner_r = radius - wall
    bottom = 0.008
    profile += [(inner_r, height)] + [(inner_r, z) for z in np.linspace(height - 0.01, bottom, 6)]
    profile += [(0.0, bottom)]
    rev = Revolution(np.asarray(profile), sections)
    # Profile point k = 1 + i is the outer ring at outer_z[i]; holes span rows k0..k0+2.
    top_k0 = 1 + round((height - 0.022) / row) - 2
    bottom_k0 = 1 + round(0.022 / row)
    j0 = 0  # columns j0 .. j0 + 2 around angle 2 pi (j0 + 1) / sections
    removed: list[int] = []
    for k0 in (top_k0, bottom_k0):
        for dk in range(2):
            for dj in range(2):
                removed.extend(rev.quad_faces[(k0 + dk, j0 + dj)])
    faces = np.delete(rev.faces, removed, axis=0)
    # Loop of the 3 x 3 vertex block boundary, as (dk, dj) offsets from the block centre.
    loop = [(-1, -1), (-1, 0), (-1, 1), (0, 1), (1, 1), (1, 0), (1, -1), (0, -1)]
    top_c, bot_c = top_k0 + 1, bottom_k0 + 1
    top_loop = [rev.vertex(top_c + dk, j0 + 1 + dj) for dk, dj in loop]
    # At the bottom end the tube's frame is flipped vertically: row offset dk maps to -dk.
    bottom_loop = [rev.vertex(bot_c - dk, j0 + 1 + dj) for dk, dj in loop]
    theta = 2 * np.pi * (j0 + 1) / sections
    e_r = np.array([np.cos(theta), np.sin(theta), 0.0])
    e_t = np.array([-np.sin(theta), np.cos(theta), 0.0])
    z_top, z_bot = rev.profile[top_c, 1], rev.profile[bot_c, 1]
    zc, half = 0.5 * (z_top + z_bot), 0.5 * (z_top - z_bot)
    dtheta = 2 * np.pi / sections
    offsets = np.array([(dj * radius * dtheta, dk * row) for dk, dj in loop])  # (t, n)
    vertices = [rev.vertices]
    rings = [top_loop]
    steps = 28
    next_index = len(rev.vertices)
    for phi in np.linspace(0.0, np.pi, steps + 1)[1:-1]:
        centre = (radius + handle_reach * np.sin(phi)) * e_r + (zc + half * np.cos(phi)) * np.array(
            [0.0, 0.0, 1.0]
        )
        tangent_rz = np.array([handle_reach * np.cos(phi), -half * np.sin(phi)])
        normal_rz = np.array([-tangent_rz[1], tangent_rz[0]]) / np.linalg.norm(tangent_rz)
        n_dir = normal_rz[0] * e_r + normal_rz[1] * np.array([0.0, 0.0, 1.0])
        ring = centre + offsets[:, :1] * e_t + offsets[:, 1:] * n_dir
        vertices.append(ring)
        rings.append(list(range(next_index, next_index + len(loop))))
        next_index += len(loop)
    rings.append(bottom_loop)
    tube: list[list[int]] = []
    m = len(loop)
    for a, b in itertools.pairwise(rings):
        for i in range(m):
            i2 = (i + 1) % m
            tube.append([a[i], b[i], b[i2]])
            tube.append([a[i], b[i2], a[i2]])
    all_vertices = np.vstack(vertices)
    tube_faces = np.asarray(tube, dtype=np.int64)
    candidate = trimesh.Trimesh(all_vertices, np.vstack([faces, tube_faces]), process=False)
    if not candidate.is_winding_consistent:
        tube_faces = tube_faces[:, ::-1]
    return _finish(all_vertices, np.vstack([faces, tube_faces]), "mug")


def banana(
    arc_radius: float = 0.12,
    arc_angle: float = 1.6,
    half_widths: tuple[float, float] = (0.018, 0.016),
    rings: int = 40,
    sections: int = 30,
) -> trimesh.Trimesh:
    """A banana-like curved object: a tapered, slightly five-sided tube along a circular arc."""
    ts = np.linspace(0.0, 1.0, rings + 2)
    psi = (ts - 0.5) * arc_angle
    path = np.column_stack(
        [arc_radius * np.sin(psi), np.zeros_like(psi), -arc_radius * np.cos(psi)]
    )
    normal = np.column_stack([-np.sin(psi), np.zeros_like(psi), np.cos(psi)])  # towards the centre
    binormal = np.array([0.0, 1.0, 0.0])
    angles = 2 * np.pi * np.arange(sections) / sections
    ridge = 1.0 + 0.05 * np.cos(5 * angles)
    vertices = [path[:1]]
    for i in range(1, rings + 1):
        taper = max(np.sin(np.pi * ts[i]) ** 0.45, 0.2)
        u = half_widths[0] * taper * ridge * np.cos(angles)
        v = half_widths[1] * taper * ridge * np.sin(angles)
        vertices.append(path[i] + u[:, None] * normal[i] + v[:, None] * binormal)
    vertices.append(path[-1:])
    vertices_arr = np.vstack(vertices)
    last = len(vertices_arr) - 1
    faces: list[list[int | np.integer]] = []
    j = np.arange(sections)
    jn = (j + 1) % sections

    def ring(i: int) -> int:
        return 1 + (i - 1) * sections

    faces.extend([0, ring(1) + a, ring(1) + b] for a, b in zip(j, jn, strict=True))
    for i in range(1, rings):
        a0, b0 = ring(i), ring(i + 1)
        for a, b in zip(j, jn, strict=True):
            faces.append([a0 + a, b0 + a, b0 + b])
            faces.append([a0 + a, b0 + b, a0 + b])
    faces.extend([ring(rings) + a, last, ring(rings) + b] for a, b in zip(j, jn, strict=True))
    return _finish(vertices_arr, np.asarray(faces), "banana")


# --------------------------------------------------------------------------------------------
# The default object set (tasks/objects/<name>/), regenerated by `harness objects build`


@dataclass(frozen=True)
class DefaultObject:
    """One object of the default set: how to build its mesh and what to record about it."""

    name: str
    category: str
    description: str
    build: Callable[[], trimesh.Trimesh]
    mass: float
    friction: float = 1.0
    orientations: tuple[tuple[float, float, float], ...] = ((0.0, 0.0, 0.0),)


FIT_FRACTION = 0.1  # a gripper "fits" an object when at least this fraction of its grasps fits

DEFAULT_OBJECTS: tuple[DefaultObject, ...] = (
    DefaultObject(
        "cube",
        "cube",
        "4 cm cube, the episode tests' object; fits every gripper",
        lambda: box((0.04, 0.04, 0.04)),
        mass=0.05,
    ),
    DefaultObject(
        "box",
        "box",
        "5 x 8 x 14 cm tea box; 5 cm side: every gripper; 8 cm side: Lift-2 (FR3 at its limit)",
        lambda: box((0.05, 0.08, 0.14)),
        mass=0.15,
        orientations=((0, 0, 0), (90, 0, 0)),
    ),
    DefaultObject(
        "can",
        "can",
        "food tin, 7.4 cm across: fits FR3 and Lift-2, not the 7 cm Piper",
        lambda: can(radius=0.037, height=0.105),
        mass=0.4,
    ),
    DefaultObject(
        "bottle",
        "bottle",
        "20 cm bottle, 6 cm body, 2.6 cm neck, 3 cm cap",
        lambda: bottle(),
        mass=0.3,
        orientations=((0, 0, 0), (90, 0, 0)),
    ),
    DefaultObject(
        "mug",
        "mug",
        "mug with a handle, 8 cm body (Lift-2, FR3 at its limit); rim and handle pinchable by all",
        lambda: mug(),
        mass=0.3,
    ),
    DefaultObject(
        "banana",
        "banana",
        "17 cm curved banana-like object, 3.3 cm thick",
        lambda: banana(),
        mass=0.15,
    ),
    DefaultObject(
        "ball",
        "ball",
        "6.4 cm ball (tennis-ball size)",
        lambda: ball(0.032),
        mass=0.06,
    ),
    DefaultObject(
        "plate",
        "plate",
        "20 cm plate, 3 mm shell: only rim pinches",
        lambda: plate(),
        mass=0.35,
    ),
    DefaultObject(
        "book",
        "book",
        "15 x 10.5 x 2.5 cm book lying flat: only edge grasps across its thickness",
        lambda: box((0.15, 0.105, 0.025)),
        mass=0.3,
    ),
)


def default_object(name: str) -> DefaultObject:
    for spec in DEFAULT_OBJECTS:
        if spec.name == name:
            return spec
    raise KeyError(f"no default object {name!r}; known: {[s.name for s in DEFAULT_OBJECTS]}")


def obj_text(mesh: trimesh.Trimesh) -> str:
    """Minimal, deterministic Wavefront OBJ (micrometre precision, 1-based triangles)."""
    lines = ["# pick-harness default object (harness objects build)"]
    lines += [f"v {x:.6f} {y:.6f} {z:.6f}" for x, y, z in np.asarray(mesh.vertices)]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in np.asarray(mesh.faces)]
    return "\n".join(lines) + "\n"
