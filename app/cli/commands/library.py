"""`wiithrow library`: the versions of a throw library, which one is in use, and going back.

    wiithrow library list  (--folder DIR | --settings S.json [--calibration cal.json] | --sim [--world W]) [--json]
    wiithrow library show N  (folder) [--json]
    wiithrow library use N   (folder) [--calibration cal.json] [--json]
    wiithrow library diff A [B]  (folder) [--json]
    wiithrow library move --to DIR  (folder) [--json]

The folder is the one a command that throws would use (`wiithrow.app.session.library_folder`):
`--folder DIR`; or the settings' `library_folder`, else beside `--calibration`, else beside the
settings (`--settings`); or a simulated world's own (`--sim [--world W]`).

* `list`: every version, oldest first: its number, parent, when, by whom and how (training,
  learning, import, migration), its throws, held-out error, area and calibration; the one in use
  marked; a learning step that was kept but not used says so.
* `show N`: one version's whole record and its library's arm, shape and ball.
* `use N`: put version N in use (an explicit choice: whatever its figures); with `--calibration`,
  a version trained with another calibration is said in one line.
* `diff A [B]`: versions A and B (default: the one in use) compared as *Finish training* compares a
  new library with the one in use (`wiithrow.app.throws.library_compare`), and the throws only one
  of them has.
* `move --to DIR`: the folder and every version in it moved to DIR (a new or empty folder; atomic
  on one file system, copied and read back otherwise, `LibraryStore.move`); with `--settings`, the
  settings file's `library_folder` is set to DIR (that key only, written atomically).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from wiithrow.app.cli.json_output import emit
from wiithrow.app.errors import AppError
from wiithrow.app.session.library_folder import library_folder, open_library_folder
from wiithrow.app.session.library_use import calibration_note
from wiithrow.app.settings import Settings
from wiithrow.app.tables import format_table
from wiithrow.app.throws.library_compare import compare_libraries, table_text
from wiithrow.app.throws.library_store import LibraryStore, VersionInfo
from wiithrow.robot import load_arm
from wiithrow.vision.files import SETTINGS_SIZE, atomic_write_text, loads_json, read_text

NAME = "library"
HELP = "the throw library's versions: list, show, use (go back), diff, move"
ACTIONS = ("list", "show", "use", "diff", "move")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from wiithrow.app.worlds.named import WORLDS

    common = argparse.ArgumentParser(add_help=False)
    where = common.add_argument_group("the library folder (one of)")
    where.add_argument("--folder", metavar="DIR", help="the library folder itself")
    where.add_argument("--settings", metavar="S.json", help="the settings' library_folder, else beside --calibration")
    where.add_argument("--calibration", metavar="cal.json", help="the calibration the library is used with")
    where.add_argument("--sim", action="store_true", help="a simulated world's library folder")
    where.add_argument("--world", choices=WORLDS, default=None, help="with --sim: the world (default: mujoco)")
    common.add_argument("--json", action="store_true", help="print the result as one JSON document")
    actions = parser.add_subparsers(dest="action", metavar="ACTION", required=True)
    actions.add_parser("list", parents=[common], help="every version, the one in use marked")
    show = actions.add_parser("show", parents=[common], help="one version's whole record")
    show.add_argument("version", type=int, metavar="N")
    use = actions.add_parser("use", parents=[common], help="put version N in use (go back)")
    use.add_argument("version", type=int, metavar="N")
    diff = actions.add_parser("diff", parents=[common], help="compare two versions (B: the one in use)")
    diff.add_argument("a", type=int, metavar="A")
    diff.add_argument("b", type=int, metavar="B", nargs="?")
    move = actions.add_parser("move", parents=[common], help="move the folder and its versions")
    move.add_argument("--to", required=True, metavar="DIR", help="a new or empty folder")


def _store(args: argparse.Namespace) -> tuple[LibraryStore, str]:
    """The library folder the flags name, and its arm."""
    given = [name for name in ("folder", "settings", "sim") if getattr(args, name)]
    if len(given) != 1:
        raise AppError("say which library folder: --folder DIR, --settings S.json [--calibration cal.json], or --sim")
    settings = Settings.load(args.settings) if args.settings else Settings()
    folder = library_folder(
        settings.arm,
        given=args.folder,
        settings_folder=settings.library_folder if args.settings else "",
        settings_path=args.settings,
        calibration_path=args.calibration,
        world=(args.world or "mujoco") if args.sim else None,
    )
    say = lambda line: print(f"wiithrow library: {line}", file=sys.stderr)  # noqa: E731
    store = open_library_folder(folder, settings.arm, say)
    return store, store.arm() or settings.arm


def run(args: argparse.Namespace) -> int:
    store, arm = _store(args)
    action = args.action
    if action == "list":
        return _list(args, store)
    if action == "show":
        return _show(args, store)
    if action == "use":
        return _use(args, store)
    if action == "diff":
        return _diff(args, store, arm)
    return _move(args, store)


def _record(info: VersionInfo, in_use: int | None) -> dict[str, Any]:
    return {**info.to_dict(), "in_use": info.id == in_use, "broken": info.broken or None}


def _in_use(store: LibraryStore) -> int | None:
    record = store.in_use_record()
    return None if record is None else record.id


def _list(args: argparse.Namespace, store: LibraryStore) -> int:
    versions, in_use = store.versions(), _in_use(store)
    if args.json:
        emit({"folder": str(store.folder), "in_use": in_use, "versions": [_record(v, in_use) for v in versions]})
        return 0
    print(f"library folder {store.folder}: {len(versions)} versions, in use: {in_use or 'none (the shipped library)'}")
    rows: list[tuple[object, ...]] = []
    for v in versions:
        if v.broken:
            rows.append((v.id, "", "", "", "", "", "", f"broken: {v.broken}"))
            continue
        what = f"{v.how} ({v.by})" + ("" if v.used_by_learning else ", not used")
        heldout = f"{1e3 * v.heldout.mean_m:.1f}" if v.heldout is not None else ""
        area = v.area.line() if v.area is not None else ""
        mark = "*" if v.id == in_use else ""
        rows.append((v.id, mark, v.parent or "", v.time, what, v.throws, heldout, area))
    print(format_table(("version", "in use", "parent", "made (UTC)", "how", "throws", "held-out mm", "area"), rows))
    return 0


def _show(args: argparse.Namespace, store: LibraryStore) -> int:
    info, library = store.load(args.version)
    in_use = _in_use(store)
    document = {
        **_record(info, in_use),
        "library": {"arm": library.arm, "throws": len(library), "shape_joints": library.shape.n},
    }
    if args.json:
        emit(document)
        return 0
    print(json.dumps(document, indent=2))
    return 0


def _use(args: argparse.Namespace, store: LibraryStore) -> int:
    before = _in_use(store)
    info = store.use(args.version, "command")
    note = ""
    if args.calibration:
        from wiithrow.vision import StereoCalibration

        note = calibration_note(info, StereoCalibration.load(args.calibration).fingerprint)
    if args.json:
        emit({"folder": str(store.folder), "in_use": info.id, "was": before, "calibration_note": note or None})
        return 0
    print(f"library version {info.id} in use ({info.how}, {info.throws} throws; was {before or 'none'})")
    if note:
        print(f"wiithrow library: {note}", file=sys.stderr)
    return 0


def _diff(args: argparse.Namespace, store: LibraryStore, arm: str) -> int:
    b = args.b if args.b is not None else _in_use(store)
    if b is None:
        raise AppError("no version is in use: give the second version (`wiithrow library diff A B`)")
    (ia, la), (ib, lb) = store.load(args.a), store.load(b)
    comparison = compare_libraries(la, lb, load_arm(arm), new_label=f"version {ia.id}", old_label=f"version {ib.id}")
    landings_a = {tuple(round(v, 6) for v in t.landing) for t in la.throws}
    landings_b = {tuple(round(v, 6) for v in t.landing) for t in lb.throws}
    throws = {
        "only_a": len(landings_a - landings_b),
        "only_b": len(landings_b - landings_a),
        "shared": len(landings_a & landings_b),
    }
    if args.json:
        emit({"a": ia.id, "b": ib.id, "comparison": comparison.to_dict(), "throws": throws})
        return 0
    for line in table_text(comparison):
        print(line)
    print(comparison.verdict())
    print(
        f"throws only in version {ia.id}: {throws['only_a']}; only in version {ib.id}: {throws['only_b']}; shared: {throws['shared']}"
    )
    return 0


def _move(args: argparse.Namespace, store: LibraryStore) -> int:
    moved = store.move(args.to)
    updated = None
    if args.settings:
        updated = _set_settings_folder(Path(args.settings), moved.folder)
    if args.json:
        emit({"from": str(store.folder), "to": str(moved.folder), "versions": len(moved.ids()), "settings": updated})
        return 0
    print(f"moved {len(moved.ids())} versions from {store.folder} to {moved.folder}")
    if updated:
        print(f"{updated}: library_folder is now {moved.folder}")
    elif not args.folder:
        print(f"commands find it with --library-folder {moved.folder} (or the settings' library_folder)")
    return 0


def _set_settings_folder(path: Path, folder: Path) -> str:
    """Set `library_folder` in the settings file at `path` (that key only), atomically."""
    document = loads_json(read_text(path, SETTINGS_SIZE), str(path))
    if not isinstance(document, dict) or not isinstance(document.get("settings", {}), dict):
        raise AppError(f"{path}: not a settings file; set its library_folder to {folder} by hand")
    document.setdefault("settings", {})["library_folder"] = str(folder)
    atomic_write_text(path, json.dumps(document, indent=2) + "\n")
    return str(path)
