"""Physics an object USD carries: its rigid body's mass and its physics material's friction.

Every InternDataEngine object USD (the examples under interndata-examples/objects) authors
``physics:mass = 0.5`` with ``UsdPhysics.MassAPI`` on the rigid-body prim (``/World/Aligned``)
and binds, for purpose "physics", a material with ``UsdPhysics.MaterialAPI`` whose static and
dynamic friction are both 1.0. The reference loads the USD as it is (its ``RigidObject`` passes
a task's ``mass`` key to Isaac's RigidPrim only when the task sets one,
workflows/simbox/core/objects/rigid_object.py lines 42-43), so these are the values it simulates.

MuJoCo has one sliding coefficient; the static one is taken (a held object stays in place by
static friction; the reference files have static = dynamic).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from pathlib import Path

from harness.objects.meshes import check_usd_layers

USD_SUFFIXES = (".usd", ".usda", ".usdc", ".usdz")


@dataclass(frozen=True)
class UsdPhysics:
    """What a USD authors; None where it authors nothing."""

    mass: float | None
    static_friction: float | None
    dynamic_friction: float | None

    @property
    def friction(self) -> float | None:
        """The coefficient MuJoCo uses: the static one, else the dynamic one."""
        return self.static_friction if self.static_friction is not None else self.dynamic_friction


NO_PHYSICS = UsdPhysics(None, None, None)


def read_usd_physics(path: str | Path) -> UsdPhysics:
    """The mass and friction a USD file authors (``NO_PHYSICS`` for other files)."""
    path = Path(path)
    if path.suffix.lower() not in USD_SUFFIXES or not path.is_file():
        return NO_PHYSICS
    return _read(path.resolve(), path.stat().st_mtime_ns)


@functools.lru_cache(maxsize=256)
def _read(path: Path, mtime_ns: int) -> UsdPhysics:
    del mtime_ns  # part of the cache key only
    # Every layer the stage would open must be a regular file under the size cap (a FIFO or a
    # device sublayer would block usd-core forever: issue 26); refused with the file named.
    # Inside the cache: a file read once is not parsed again for the check.
    check_usd_layers(path)
    from pxr import Usd, UsdShade
    from pxr import UsdPhysics as Physics

    try:
        stage = Usd.Stage.Open(str(path))
    except Exception:  # pxr.Tf.ErrorException: the mesh loader reports it, naming the file
        return NO_PHYSICS
    if stage is None:
        return NO_PHYSICS
    mass = static = dynamic = None
    for prim in stage.Traverse():
        if mass is None and prim.HasAPI(Physics.MassAPI):
            value = Physics.MassAPI(prim).GetMassAttr().Get()
            if value is not None and float(value) > 0:  # 0 means "not set" in UsdPhysics
                mass = float(value)
        if static is None and dynamic is None:
            material = _physics_material(prim, UsdShade)
            if material is not None and material.GetPrim().HasAPI(Physics.MaterialAPI):
                api = Physics.MaterialAPI(material.GetPrim())
                static = _authored(api.GetStaticFrictionAttr())
                dynamic = _authored(api.GetDynamicFrictionAttr())
    return UsdPhysics(mass, static, dynamic)


def _physics_material(prim, UsdShade):
    """The material bound to ``prim`` for purpose "physics" (None when there is none)."""
    if not prim.HasAPI(UsdShade.MaterialBindingAPI):
        return None
    binding = UsdShade.MaterialBindingAPI(prim)
    material, _relationship = binding.ComputeBoundMaterial("physics")
    return material if material else None


def _authored(attribute) -> float | None:
    if not attribute or not attribute.HasAuthoredValue():
        return None
    return float(attribute.Get())
