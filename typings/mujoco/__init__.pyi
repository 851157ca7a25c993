# MuJoCo's Python bindings are compiled (pybind11) and ship no type information, so pyright
# cannot see `mujoco.MjModel`, `mujoco.mj_step`, ...; this stub types every attribute as Any.
from typing import Any

__version__: str

def __getattr__(name: str) -> Any: ...
