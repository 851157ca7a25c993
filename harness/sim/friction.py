"""How an object's friction meets the pads' and the table's: the reference engine's rule.

MuJoCo combines the friction of two touching geoms by taking the larger coefficient, so with
high-friction finger pads the object's own ``friction`` never mattered (0.05 and 1.5 gave the
same outcomes, issue 16 item 4). The reference simulates in Isaac Sim / PhysX, whose default
friction combine mode is the *average* of the two materials' coefficients. This module makes
every object-pad and object-table contact an explicit MuJoCo contact pair whose friction is that
average (sliding, torsional and rolling each), with the pad's contact stiffness for object-pad
contacts. The torsional coefficient of an object-pad pair is the pad's contact patch instead
(``pad_pair_friction``): PhysX has no torsional material coefficient (a patch resists a twist
through its area), and a patch's torsional limit is (3 pi / 16) mu a N
(``tests/contact_patch.py``), so the pad's ``pad_torsion`` (derived at its own sliding
friction) is scaled to the pair's averaged sliding friction. An explicit pair replaces the
dynamic contact of the same two geoms, so nothing is counted twice. Object-object contacts keep
MuJoCo's rule (the larger coefficient).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

import mujoco

PAIR_CONDIM = 4  # sliding + torsional friction, as the pads and the objects


def combined_friction(a: Sequence[float], b: Sequence[float]) -> list[float]:
    """PhysX's default combine mode (average) per coefficient, as MuJoCo's 5-vector
    (sliding, sliding, torsional, rolling, rolling)."""
    slide, spin, roll = ((float(a[i]) + float(b[i])) / 2.0 for i in range(3))
    return [slide, slide, spin, roll, roll]


def pad_pair_friction(obj: Sequence[float], pad: Sequence[float]) -> list[float]:
    """An object-pad pair: the averages of ``combined_friction``, except the torsional
    coefficient, the pad patch's torsion at the pair's sliding friction
    (pad torsion x pair sliding / pad sliding; the patch limit is proportional to mu)."""
    friction = combined_friction(obj, pad)
    friction[2] = float(pad[1]) * friction[0] / float(pad[0])
    return friction


def add_object_contact_pairs(
    spec: mujoco.MjSpec, object_geoms: Iterable[str], pad_geoms: Iterable[str], table_geom: str
) -> int:
    """Explicit pairs for each object geom with every finger pad and the table; returns how
    many were added."""
    geoms = {geom.name: geom for geom in spec.geoms if geom.name}
    pads = [geoms[name] for name in pad_geoms]
    table = geoms[table_geom]
    added = 0
    for name in object_geoms:
        obj = geoms[name]
        for pad in pads:
            spec.add_pair(
                geomname1=pad.name,
                geomname2=name,
                condim=PAIR_CONDIM,
                friction=pad_pair_friction(obj.friction, pad.friction),
                solref=list(pad.solref),
            )
            added += 1
        spec.add_pair(
            geomname1=table.name,
            geomname2=name,
            condim=PAIR_CONDIM,
            friction=combined_friction(obj.friction, table.friction),
        )
        added += 1
    return added
