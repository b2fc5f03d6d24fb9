"""A package's public names imported when first used (PEP 562's module `__getattr__`).

`wiithrow.vision`, `wiithrow.vision.wiimote` and `wiithrow.app.recording` re-export what their submodules define. Imported
eagerly, their `__init__` loaded every submodule: a process that needs one (a publisher's writer
process reading `vision.files` and `vision.wiimote.frames`) paid 0.4 s of CPU at its start for
scipy's optimisers and the numba kernels it never calls. With `lazy_exports`, `import
wiithrow.vision` loads nothing but the package, and `wiithrow.vision.calibrate` imports
`wiithrow.vision.dlt` the first time it is read (then it is an ordinary attribute). Static tools
(mypy, pyright, IDEs) read the same names from the package's `if TYPE_CHECKING:` imports.
"""

from __future__ import annotations

import importlib
import sys
from collections.abc import Callable, Mapping
from typing import Any


def lazy_exports(package: str, homes: Mapping[str, str]) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """The `__getattr__` and `__dir__` of `package` (its `__name__`) whose public names live in the
    submodules `homes` gives (name -> submodule, relative to the package)."""
    namespace = sys.modules[package].__dict__

    def __getattr__(name: str) -> Any:
        home = homes.get(name)
        if home is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(f"{package}.{home}"), name)
        namespace[name] = value  # once: later reads find it without this function
        return value

    def __dir__() -> list[str]:
        return sorted(set(namespace) | set(homes))

    return __getattr__, __dir__
