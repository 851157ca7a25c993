# usd-core's Python bindings are compiled (boost.python) and ship no type information, so pyright
# cannot see `Usd.Stage`, `UsdGeom.Mesh`, ...; this stub types every attribute as Any.
from typing import Any

def __getattr__(name: str) -> Any: ...
