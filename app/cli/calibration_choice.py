"""Which calibration `wiithrow train` and `wiithrow throw` measure with, and the lines that say so.

`choose_calibration` decides, in this order:

1. `--calibration FILE`: that file;
2. `--recalibrate` (simulation): a new robot calibration of the simulated rig;
3. else the newest calibration file in the current folder, the folder `wiithrow calibrate` writes to
   (`calibration.json` by default, or the file its `--out` names), made for this command's arm, rig
   and world: a simulated world's calibration (`meta.simulated`, `meta.world`) for that simulated
   world, a hardware calibration (made with the same settings file when it names one) for the
   hardware path. Newest is the file's modification time (`ls -t`). A calibration file there that
   is newer than the one chosen (or any, when none fits) and made for another arm, world or rig is
   named with why it is not used, one line each (`SKIPPED_LINES` at most, then a count): never
   passed over silently;
4. else what the command did without a calibration: in simulation the simulated rig's own robot
   calibration (`wiithrow.app.calibration.simulated`: the last one kept, reused while valid); on the
   hardware path none (the command says to pass `--calibration`).

The choice is said in one line, `calibration: FILE (why; how to choose another)`, which the command
prints after its world line (`CalibrationChoice.lines`); `to_dict` is what `--json` reports.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from wiithrow.app.errors import AppError
from wiithrow.vision import StereoCalibration, VisionError
from wiithrow.vision.files import CALIBRATION_SIZE
from wiithrow.vision.stereo_calibration import FILE_KIND

How = Literal["given", "newest", "recalibrate", "simulated", "none"]

#: How many passed-over calibration files are named, one line each, before the rest are counted.
SKIPPED_LINES = 3
#: How much of a JSON file is read to tell whether it is a calibration (its "kind" comes first).
HEAD_BYTES = 4096
_KIND = re.compile(r'"kind"\s*:\s*"' + re.escape(FILE_KIND) + '"')


@dataclass(frozen=True)
class CalibrationChoice:
    """The calibration a command measures with (module docstring). `calibration`: None for the
    simulated rig's own robot calibration (`how` "recalibrate" or "simulated") and for none at all
    on the hardware path ("none"); `path`: the file, as given or as found in the current folder."""

    how: How
    calibration: StereoCalibration | None = None
    path: str | None = None
    lines: tuple[str, ...] = field(default=())
    skipped: tuple[tuple[str, str], ...] = field(default=())

    def to_dict(self, fingerprint: str | None) -> dict[str, Any]:
        """The choice as `--json` reports it; `fingerprint`: the calibration the rig measures with."""
        return {"file": self.path, "chosen": self.how, "fingerprint": fingerprint}


def world_words(world: str | None, settings_path: str | None) -> str:
    """The world a calibration is chosen for, as the lines name it."""
    if world is not None:
        return f"the {'MuJoCo' if world == 'mujoco' else world} world"
    return f"the hardware path with settings {settings_path}"


def choose_calibration(
    *,
    given: str | None,
    recalibrate: bool,
    arm: str,
    remotes: int,
    world: str | None,
    settings_path: str | None = None,
    folder: Path | None = None,
) -> CalibrationChoice:
    """The calibration for a command on arm `arm` with `remotes` remotes, in simulated world `world`
    (None: the hardware path of `settings_path`), looked for in `folder` (default: the current
    folder) when neither `given` (`--calibration`) nor `recalibrate` (module docstring)."""
    if given:
        return CalibrationChoice(
            "given", StereoCalibration.load(given), given, (f"calibration: {given} (--calibration)",)
        )
    if recalibrate:
        return CalibrationChoice(
            "recalibrate", lines=("calibration: a new robot calibration of the simulated rig (--recalibrate)",)
        )
    where = folder if folder is not None else Path.cwd()
    skipped: list[tuple[str, str]] = []
    for path in _calibration_files(where):
        try:
            calibration = StereoCalibration.load(path)
        except VisionError as exc:
            skipped.append((path.name, str(exc)))
            continue
        why = mismatch(calibration, arm=arm, remotes=remotes, world=world, settings_path=settings_path, folder=where)
        if why is not None:
            skipped.append((path.name, why))
            continue
        name = path.name if folder is None else str(path)
        make = (
            "--recalibrate to make a new one"
            if world is not None
            else "`wiithrow calibrate --robot --settings` to make a new one"
        )
        line = (
            f"calibration: {name} (the newest calibration in {'this folder' if folder is None else where} for arm "
            f"{arm} in {world_words(world, settings_path)}; --calibration to choose another, {make})"
        )
        return CalibrationChoice("newest", calibration, name, (*_skipped_lines(skipped, newer=True), line))
    lines = _skipped_lines(skipped, newer=False)
    if world is None:
        return CalibrationChoice("none", lines=tuple(lines), skipped=tuple(skipped))
    fallback = (
        f"calibration: the simulated rig's robot calibration (no calibration file in "
        f"{'this folder' if folder is None else where} for arm {arm} in {world_words(world, None)}; --calibration "
        "to choose one, --recalibrate to make a new one)"
    )
    return CalibrationChoice("simulated", lines=(*lines, fallback))


def required_on_hardware(choice: CalibrationChoice, what: str, arm: str) -> StereoCalibration:
    """The calibration chosen on the hardware path; AppError saying to pass one when none was found
    (`what`: what the command does with the rig), naming the newest file passed over and why."""
    if choice.calibration is not None:
        return choice.calibration
    passed = f" ({choice.skipped[0][0]}: {choice.skipped[0][1]})" if choice.skipped else ""
    raise AppError(
        f"{what}: pass --calibration cal.json (from `wiithrow calibrate --robot --settings S.json`; no calibration "
        f"file in this folder was made for arm {arm} with these settings{passed})"
    )


def mismatch(
    calibration: StereoCalibration,
    *,
    arm: str,
    remotes: int,
    world: str | None,
    settings_path: str | None,
    folder: Path,
) -> str | None:
    """Why `calibration`, found in `folder`, is not for this command's arm, rig and world (None: it is)."""
    if calibration.arm != arm:
        return (
            f"made on arm {calibration.arm}, not {arm}" if calibration.arm else f"it does not say its arm ({arm} here)"
        )
    if calibration.frame != "link1":
        return f"in frame {calibration.frame}, not link1 (the rig on the arm)"
    if len(calibration.cameras) != remotes:
        return f"{len(calibration.cameras)} cameras for a rig of {remotes} remotes"
    meta = calibration.meta
    simulated = meta.get("simulated") is True
    made_in = meta.get("world") if isinstance(meta.get("world"), str) else None
    if world is not None:
        if not simulated:
            return f"made on the hardware path, not in {world_words(world, None)}"
        if made_in != world:
            return f"made in {world_words(made_in, None) if made_in else 'a simulated world it does not name'}, not in {world_words(world, None)}"
        return None
    if simulated:
        return f"made in the simulated {made_in or 'rig'}{' world' if made_in else ''}, not on the hardware path"
    made_with = meta.get("settings")
    other = isinstance(made_with, str) and settings_path is not None
    if other and (folder / str(made_with)).resolve() != Path(str(settings_path)).resolve():
        return f"made with settings {made_with}, not {settings_path}"
    return None


def _calibration_files(folder: Path) -> list[Path]:
    """The calibration files directly in `folder`, newest first (by modification time, then name)."""
    found = []
    for path in folder.glob("*.json"):
        try:
            stat = path.stat()
            if not path.is_file() or stat.st_size > CALIBRATION_SIZE.max_bytes:
                continue
            with path.open("rb") as handle:
                head = handle.read(HEAD_BYTES).decode("utf-8", errors="replace")
        except OSError:
            continue
        if _KIND.search(head):
            found.append((stat.st_mtime_ns, path.name, path))
    return [path for _, _, path in sorted(found, key=lambda item: (-item[0], item[1]))]


def _skipped_lines(skipped: list[tuple[str, str]], *, newer: bool) -> list[str]:
    """One line per passed-over calibration file (`SKIPPED_LINES` at most, then a count)."""
    lines = [
        f"calibration: not using {name}{' (newer)' if newer else ''}: {why}" for name, why in skipped[:SKIPPED_LINES]
    ]
    if len(skipped) > SKIPPED_LINES:
        lines.append(f"calibration: not using {len(skipped) - SKIPPED_LINES} more calibration files here either")
    return lines
