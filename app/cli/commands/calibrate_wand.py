"""`wiithrow calibrate --wand`: calibrate 2-4 remotes with a wand, without a robot.

    wiithrow calibrate --wand --sim [--cameras N] [--seconds 60] [--wand-length 0.3] [--frame camera|lframe|robot]
    wiithrow calibrate --wand --points wand.csv --wand-length L
    wiithrow calibrate --wand --wand-length L [--cameras N] [--seconds 60] [--frame ...] [--settings S.json]

`wiithrow.app.cli.commands.calibrate` dispatches `--wand` here. Three sources of wand dots:

* `--sim`: the simulated world with --cameras remotes placed by the settings; a simulated person
  waves a 0.3 m wand for `--seconds` in front of them (`SimWorld.wave_wand`; the dots go through
  the remotes' HID bytes); `--wand-length` is what the calibration is told (default 0.3 m, so a
  wrong one can be tried); `--frame lframe` then puts a simulated L-frame on a table in view
  (arms 0.30 and 0.20 m), `--frame robot` has the simulated arm show its LED;
* `--points wand.csv`: a recording (`wiithrow.vision.wand.wand_csv`); only the first camera's frame;
* neither: the real remotes (the first `rig.count` hidapi finds, or --cameras), recorded for
  `--seconds` with a progress bar and each camera's coverage; `--frame lframe` asks for the
  L-frame, `--frame robot` needs the settings' arm driver.

Then the fit (`wiithrow.vision.wand.calibrate_wand`), the report (per camera: reprojection RMS,
focal length, principal point, coverage; the wand length's mean, standard deviation and wand
score; the held-out error; the frame's residual; warnings) and the calibration file (`--out`),
the same file the robot calibration writes. `--record FILE.csv` also keeps the recording.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

import numpy as np

from wiithrow.app.calibration.versions import keep_and_compare
from wiithrow.app.calibration.wand import Frame, WandRun, calibrate_with_wand, parse_frame
from wiithrow.app.calibration.wand_capture import CaptureProgress
from wiithrow.app.cli.arguments import camera_count, output_file, positive_float, refuse_flags
from wiithrow.app.cli.json_output import emit
from wiithrow.app.cli.world_choice import hardware_world_line, say_world, sim_world_line, sim_world_name
from wiithrow.app.errors import AppError
from wiithrow.app.progress import progress_bar
from wiithrow.app.settings import Settings
from wiithrow.app.tables import format_table
from wiithrow.vision import StereoCalibration
from wiithrow.vision.outputs import OutputFiles
from wiithrow.vision.wand.calibrate import WandCalibration, calibrate_wand
from wiithrow.vision.wand.wand_csv import read_wand_csv, wand_csv_text

DEFAULT_SECONDS = 60.0
#: The simulated wand's length (m), and what the calibration is told when --wand-length is not given.
SIM_WAND_M = 0.3
#: Where the simulated L-frame lies (link1, m): the corner, the x arm's end (0.30 m), the y arm's (0.20 m).
SIM_LFRAME = np.array([[0.9, 0.15, 0.1], [0.9, -0.15, 0.1], [1.1, 0.15, 0.1]])
SIM_LFRAME_ARMS_M = (0.30, 0.20)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The options only --wand uses (`calibrate` adds --wand itself and the shared ones)."""
    wand = parser.add_argument_group("--wand")
    wand.add_argument(
        "--wand-length", type=positive_float, metavar="L", help="distance between the wand's LED centres (m)"
    )
    wand.add_argument(
        "--seconds", type=positive_float, help=f"how long to record the waving (default: {DEFAULT_SECONDS:g} s)"
    )
    wand.add_argument(
        "--cameras", type=camera_count, help="remotes in the rig, 2 to 4 (default: the settings' rig.count)"
    )
    wand.add_argument(
        "--settings",
        help="settings JSON: where the remotes are, the arm's driver (--wand with real remotes; --robot: the arm, hand "
        "and remotes drivers it names, the hardware path)",
    )
    wand.add_argument(
        "--lframe-lengths",
        type=positive_float,
        nargs=2,
        metavar=("LX", "LY"),
        help="with --frame lframe: the L-frame's arm lengths (m), which then check the wand's length",
    )
    wand.add_argument("--record", metavar="FILE.csv", help="also write the recorded wand dots as a wand CSV")


#: The options only --wand uses (`calibrate` refuses them in its other modes).
WAND_OPTIONS = ("wand_length", "seconds", "cameras", "settings", "lframe_lengths", "record")


def _frame(args: argparse.Namespace) -> Frame:
    return parse_frame(args.frame or "camera")


def run_wand_calibration(args: argparse.Namespace) -> int:
    if not args.sim:
        refuse_flags(args, ("world",), "without --sim (it names the simulated world)")
    refuse_flags(args, ("method", "dlt_csv"), "to --wand (it fits the remotes' intrinsics and poses, not DLT matrices)")
    frame = _frame(args)
    from wiithrow.app.cli.commands.calibrate import DEFAULT_OUT

    out = output_file(args, "out", DEFAULT_OUT)
    record = output_file(args, "record")
    assert out is not None
    if record is not None and record.resolve() == out.resolve():
        raise AppError(f"--out and --record name the same file ({out}): give two files")
    if args.points is not None:
        return _from_csv(args, frame, out)
    if frame != "lframe":
        refuse_flags(args, ("lframe_lengths",), f"to --frame {frame}")
    seconds = DEFAULT_SECONDS if args.seconds is None else args.seconds
    length = args.wand_length
    if length is None:
        if not args.sim:
            raise AppError("give the wand's length: --wand-length L (m, between the LED centres)")
        length = SIM_WAND_M
    settings = Settings.load(args.settings) if args.settings else Settings()
    if args.cameras is not None:
        settings = settings.with_cameras(args.cameras)
    world = _world(args, settings)
    lframe_lengths = tuple(args.lframe_lengths) if args.lframe_lengths else None
    rng = np.random.default_rng(args.seed or 0)
    if args.sim:
        world.held.wave_wand(seconds, SIM_WAND_M, rng)
        lframe_lengths = lframe_lengths or SIM_LFRAME_ARMS_M
    bar = _Bar(seconds, world.camera_names(), show=not args.json)
    try:
        run = calibrate_with_wand(
            world,
            seconds=seconds,
            wand_length_m=length,
            frame=frame,
            lframe_lengths_m=lframe_lengths,
            rng=rng,
            progress=bar.update,
            before_frame=lambda name: _before_frame(world, name, args),
            show_progress=not args.json,
        )
    finally:
        bar.close()
        world.close()
    keep_and_compare(out, run.calibration, _say_replaced)
    files = OutputFiles().add(out, run.calibration.write_json)
    if record is not None:
        files.add(record, wand_csv_text(run.result.observations))
    files.commit()
    _report(args, run.result, run.calibration, run, str(out))
    return 0


def _world(args: argparse.Namespace, settings: Settings) -> Any:
    """The simulated world `--world` names (MuJoCo by default; both have a simulated person,
    `held`), or the remotes (and arm) of the settings; its first line said on stderr."""
    if args.sim:
        from wiithrow.app.worlds.named import make_world

        name = sim_world_name(args)
        say_world(sim_world_line(name))
        return make_world(name, settings, seed=args.seed or 0)
    from wiithrow.app.worlds.hardware import HardwareWorld

    say_world(hardware_world_line(settings, args.settings))

    # a settings file runs the code its drivers name: say what ran (docs/bring-up/settings.md, "Settings files run code")
    return HardwareWorld(
        settings, on_load=lambda d: print(f"wiithrow calibrate: loaded {d}", file=sys.stderr, flush=True)
    )


def _before_frame(world: Any, name: str, args: argparse.Namespace) -> None:
    """The wand is put away; the L-frame is put down (asked for, or simulated)."""
    if args.sim:
        world.held.hold(SIM_LFRAME if name == "lframe" else None)
    elif name == "lframe":
        print(
            "put the wand away and the L-frame down in view of every remote (its three LEDs the only lit "
            "IR sources), then press Enter",
            file=sys.stderr,
            flush=True,
        )
        sys.stdin.readline()


def _from_csv(args: argparse.Namespace, frame: Frame, out: Path) -> int:
    if args.sim:
        raise AppError("--points wand.csv and --sim are two sources of wand dots: give one")
    refuse_flags(
        args, ("seconds", "cameras", "record", "lframe_lengths"), "to --points wand.csv (a recording made already)"
    )
    if frame != "camera":
        raise AppError(
            f"--frame {frame} needs the rig live (the L-frame's LEDs, the arm's poses); a wand CSV gives the "
            "first camera's frame"
        )
    if args.wand_length is None:
        raise AppError("give the wand's length: --wand-length L (m, between the LED centres)")
    observations = read_wand_csv(args.points)
    settings = Settings.load(args.settings) if args.settings else Settings()
    result = calibrate_wand(
        observations,
        args.wand_length,
        focal_px=settings.rig.focal_px,
        center_px=settings.rig.center_px,
        rng=np.random.default_rng(args.seed or 0),
    )
    calibration = StereoCalibration(
        result.calibration.cameras,
        result.calibration.frame,
        None,
        {**result.calibration.meta, "csv": str(args.points)},
    )
    keep_and_compare(out, calibration, _say_replaced)
    OutputFiles().add(out, calibration.write_json).commit()
    _report(args, result, calibration, None, str(out))
    return 0


class _Bar:
    """The recording's progress bar on stderr, with each camera's coverage so far."""

    def __init__(self, seconds: float, names: Any, show: bool) -> None:
        self.names = list(names)
        self.bar = progress_bar(total=round(seconds, 1), desc="waving the wand", unit="s", show=show, leave=False)

    def update(self, p: CaptureProgress) -> None:
        self.bar.n = round(p.done * self.bar.total, 1)
        self.bar.set_postfix_str(
            "coverage " + ", ".join(f"{n} {100 * f:.0f}%" for n, f in zip(self.names, p.coverage_fraction))
        )

    def close(self) -> None:
        self.bar.close()


def report_dict(result: WandCalibration, calibration: StereoCalibration, run: WandRun | None) -> dict[str, Any]:
    """The calibration as JSON-ready data."""
    q = result.quality.to_dict()
    for entry, camera in zip(q["cameras"], result.calibration.cameras):
        K = camera.decompose().K
        entry["focal_px"] = float(K[0, 0])
        entry["principal_point_px"] = [float(K[0, 2]), float(K[1, 2])]
    fit = run.frame_fit if run is not None else None
    return {
        "frame": calibration.frame,
        "wand_length_m": result.wand_length_m,
        **q,
        "frame_fit": None
        if fit is None
        else {
            "rms_m": fit.rms_m,
            "max_m": float(fit.residuals_m.max()),
            "points": len(fit.residuals_m),
            "scale": fit.scale,
        },
        "fit_s": result.bundle.seconds,
    }


def _report(
    args: argparse.Namespace, result: WandCalibration, calibration: StereoCalibration, run: WandRun | None, path: str
) -> None:
    document = report_dict(result, calibration, run)
    if args.json:
        emit({"calibration": path, **document})
        return
    rows = [
        (
            c["name"],
            c["observations"],
            c["reprojection_rms_px"],
            c["focal_px"],
            *c["principal_point_px"],
            100 * c["coverage"],
        )
        for c in document["cameras"]
    ]
    q = result.quality
    lines = [
        format_table(["camera", "dots", "RMS px", "focal px", "cx px", "cy px", "coverage %"], rows),
        "",
        f"wand length {1e3 * q.length_mean_m:.2f} mm +- {1e3 * q.length_std_m:.2f} mm over {q.frames_usable} frames: "
        f"wand score {q.wand_score_percent:.2f} % ({q.frames_fitted} frames fitted, {q.length_outliers} left out "
        "as outliers)",
        f"held-out error: {1e3 * q.heldout_length_rms_m:.2f} mm RMS of the wand length over {q.heldout_frames} frames "
        "never fitted",
    ]
    if run is not None and run.frame_fit is not None:
        fit = run.frame_fit
        lines.append(
            f"frame {calibration.frame}: {len(fit.residuals_m)} points fit it to {1e3 * fit.rms_m:.2f} mm RMS "
            f"(worst {1e3 * fit.residuals_m.max():.2f} mm); their scale {fit.scale:.4f}"
        )
    else:
        lines.append(f"frame {calibration.frame}: the first camera's (x right, y down, z along its axis)")
    lines += [f"warning: {w}" for w in q.warnings]
    lines.append(f"wrote {path}")
    print("\n".join(lines))


def _say_replaced(line: str) -> None:
    print(f"wiithrow calibrate: {line}", file=sys.stderr)
