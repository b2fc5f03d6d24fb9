"""Where driver reports are kept, and what a throw on hardware asks of them (`driver_report_status`).

`wiithrow check-driver --settings S.json` writes its report (atomically, a versioned JSON document
of kind `wiithrow.driver-report`) to two places:

* beside the settings: `S.driver-report.json` for `S.json` (`report_path_for`), or `--out`;
* the cache: `<cache>/driver-reports/<key>.json` (`cached_report_path`), where `<cache>` is
  $WIITHROW_CACHE_DIR, else $XDG_CACHE_HOME/wiithrow, else ~/.cache/wiithrow (the folder the
  simulated rig keeps its calibrations in), and `<key>` a hash of what the report is about: the
  arm and its `arm_driver` and `gripper_driver`, so that a copy of the settings elsewhere, or
  settings given in another file, find the report of the same drivers.

`driver_report_status(settings, settings_path)` looks beside the settings first, then in the
cache; it returns None when a report of these drivers passed, else one line saying why not (none
found, or the last one failed and which checks), for a throw or `wiithrow serve` to warn with.
A report of other drivers (the settings changed since) does not count.
"""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path

from wiithrow.app.drivercheck.report import REPORT_KIND, REPORT_SCHEMA, DriverReport
from wiithrow.app.settings import Settings
from wiithrow.vision.errors import FileFormatError
from wiithrow.vision.files import read_versioned_json, write_versioned_json

#: The suffix of a report beside its settings file.
REPORT_SUFFIX = ".driver-report.json"


def report_path_for(settings_path: str | os.PathLike[str]) -> Path:
    """`S.driver-report.json` beside `S.json`."""
    path = Path(settings_path)
    return path.with_name(path.stem + REPORT_SUFFIX)


def cache_dir() -> Path:
    """The user's cache folder of wiithrow (module docstring)."""
    if os.environ.get("WIITHROW_CACHE_DIR"):
        return Path(os.environ["WIITHROW_CACHE_DIR"])
    return Path(os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")) / "wiithrow"


def driver_identity(settings: Settings) -> dict[str, str]:
    """What a report is about: the arm and the drivers the settings name."""
    return {"arm": settings.arm, "arm_driver": settings.arm_driver, "gripper_driver": settings.gripper_driver}


def cached_report_path(settings: Settings) -> Path:
    """The cache's report of the drivers `settings` name (module docstring)."""
    key = hashlib.sha256(json.dumps(driver_identity(settings), sort_keys=True).encode()).hexdigest()[:16]
    return cache_dir() / "driver-reports" / f"{key}.json"


def save_report(report: DriverReport, path: str | os.PathLike[str]) -> Path:
    """Write `report` to `path` atomically."""
    return write_versioned_json(path, REPORT_KIND, REPORT_SCHEMA, report.to_dict())


def driver_report_status(settings: Settings, settings_path: str | os.PathLike[str] | None = None) -> str | None:
    """None when a passing report of the drivers `settings` name is kept (beside `settings_path`,
    or in the cache), else one line saying why not. Settings naming no arm driver: None (there is
    nothing to check; the arm is parked)."""
    if not settings.arm_driver:
        return None
    identity = driver_identity(settings)
    places = ([report_path_for(settings_path)] if settings_path is not None else []) + [cached_report_path(settings)]
    failed: str | None = None
    for path in places:
        try:
            if not path.is_file():
                continue
            document = read_versioned_json(path, REPORT_KIND, REPORT_SCHEMA)
        except OSError:  # a folder it may not read: no report there
            continue
        except FileFormatError as exc:
            failed = failed or f"the driver report {exc}"
            continue
        if {key: document.get(key) for key in identity} != identity:
            continue  # a report of other drivers
        if document.get("passed") is True:
            return None
        names = [c.get("name", "?") for c in document.get("checks", []) if not c.get("passed")]
        failed = failed or (
            f"the last check of arm_driver {settings.arm_driver!r} ({path}) did not pass: {', '.join(names) or '?'}"
        )
    hint = f"`wiithrow check-driver --settings {settings_path or 'S.json'}`"
    if failed is not None:
        return f"{failed}; fix the driver and run {hint} before throwing"
    return f"arm_driver {settings.arm_driver!r} has no passing driver report: run {hint} before throwing"
