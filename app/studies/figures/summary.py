"""`summary.md` of `wiithrow reproduce`: our measured numbers beside the paper's claims.

One function per section (the claims table, the rig, Fig. 4, the pose spreads, Fig. 6, the
files); `summary_markdown` joins them.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from wiithrow.app.calibration.poses import DesignScore
from wiithrow.app.tables import format_table

if TYPE_CHECKING:
    from wiithrow.app.studies.reproduce import Reproduction


def _mm(value: float | np.floating, digits: int = 2) -> str:
    return "n/a" if not np.isfinite(value) else f"{1e3 * value:.{digits}f} mm"


def _md_table(headers: Sequence[str], rows: Sequence[Sequence[object]]) -> str:
    lines = ["| " + " | ".join(headers) + " |", "|" + "|".join("---" for _ in headers) + "|"]
    lines += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    return "\n".join(lines)


def summary_markdown(r: Reproduction) -> str:
    """The summary of a reproduction: the claims table, then one section per study."""
    sections = [_header(r), _claims(r), _rig(r), _fig4(r), _designs(r), _fig6(r), _files(r)]
    return "\n\n".join(sections) + "\n"


def _ratio_text(runs: list[DesignScore], quick: bool) -> str:
    """Mean ratio of the runs' test errors to the true cameras', or why there is none."""
    if runs:
        return f"x{np.mean([x.ratio for x in runs]):.3f}"
    return "not run in a quick run" if quick else "no run"


def _header(r: Reproduction) -> str:
    cfg, s = r.config, r.settings
    return (
        "# wiithrow reproduce: the simulated system beside the paper\n\n"
        f"Run: {'quick' if cfg.quick else 'full'}, seed {r.seed}; arm {s.arm}; pixel noise {s.noise.pixel_sigma_px} px "
        f"before rounding; joint tracking error {1e3 * s.noise.joint_tracking_rad:.1f} mrad; "
        f"{r.data.image.shape[0]} simulated Wiimotes (f = {s.rig.focal_px:.0f} px) speaking the HID protocol, "
        "the arm driven through its Ruckig moves. Paper: Petric, Gams, Ude, Zlajpah (2010).\n\n"
        + (
            "World: MuJoCo (a servo-driven arm with manufacturing tolerances; the robot's forward kinematics, the "
            "calibration's ground truth, is slightly wrong as on a real arm); Fig. 6 in the kinematic world, "
            "whose hand carries the beacon pair."
            if r.world == "mujoco"
            else "World: kinematic (the planner's own models)."
        )
    )


def _claims(r: Reproduction) -> str:
    """The paper's claims beside our numbers, one row per figure or claim."""
    cfg, fig4, fig6, a = r.config, r.fig4, r.fig6, r.alignment
    N = fig4.sizes[-1]
    rel30 = dict(zip(fig4.sizes, fig4.relative("refined"))).get(30, float("nan"))
    stereo_depth = np.abs(fig6.depth_error("stereo"))
    mono_depth = np.abs(fig6.depth_error("mono"))

    def at(angle: float) -> int:
        return int(np.argmin(np.abs(fig6.angle_deg - angle)))

    robot = {d: [sc for _, sc in runs] for d, runs in r.robot30.items()}
    ideal = {d: np.mean([x.ratio for x in v]) for d, v in r.designs.items()}
    rows = [
        [
            "Fig. 4: error against the number of calibration points",
            "minimal from about 30 points",
            f"refined: within 10 % of its {N}-point value from n = {fig4.knee('refined')} on; at 30 points "
            f"{rel30:.3f} x the {N}-point error (paired: the same points' error with all {N})"
            + (" (quick run: N = 30, so this cannot be judged)" if N <= 30 else ""),
        ],
        [
            "Robot-driven calibration (LED on the hand, FK as ground truth)",
            "stereo rig calibrated in the robot's frame",
            f"{len(r.data)} poses, {r.data.duration_s:.0f} s of arm time: leave-one-out {_mm(r.loo_all_m, 3)}; "
            f"RMS {', '.join(f'{c.rms_px:.2f}' for c in r.calibration.cameras)} px",
        ],
        [
            "30 poses against the true cameras (ratio of 3D test errors on the same noisy pixels)",
            "(no ground truth cameras)",
            f"optimal spread {_ratio_text(robot['optimal'], cfg.quick)} (robot), x{ideal['optimal']:.3f} "
            f"(ideal, {cfg.design_seeds} seeds); random {_ratio_text(robot['random'], cfg.quick)} (robot), "
            f"x{ideal['random']:.3f} (ideal); goal <= 1.10",
        ],
        [
            "Fig. 5: actual against calculated positions",
            "they agree",
            f"RMS x, y, z: {', '.join(f'{1e3 * v:.2f}' for v in r.fig5.rms_m)} mm; mean 3D {_mm(r.fig5.mean_abs_3d_m, 3)}",
        ],
        [
            "Fig. 6: stereo against mono",
            "stereo much better; mono wrong when the beacon line is not parallel to the image plane",
            f"stereo depth error <= {_mm(stereo_depth.max())} at every angle; mono {_mm(mono_depth[at(0)], 1)} at "
            f"{fig6.angle_deg[at(0)]:.0f} deg, {_mm(mono_depth[at(30)], 1)} at {fig6.angle_deg[at(30)]:.0f} deg, "
            f"{_mm(mono_depth[at(60)], 0)} at {fig6.angle_deg[at(60)]:.0f} deg",
        ],
        [
            "Tracking part of the throw (joint 1 turns the target into y = 0)",
            "about 10 s",
            f"{a.status} in {a.duration_s:.1f} s from a target {np.degrees(1.2):.0f} deg outside the view "
            f"(search sweep, then |y| = {_mm(abs(a.y_m))})",
        ],
    ]
    return "## The paper's claims and our numbers\n\n" + _md_table(["claim", "paper", "ours"], rows)


def _rig(r: Reproduction) -> str:
    """The rig's coverage of the throw plane and the spread of the calibration poses."""
    rig, cov, W = r.settings.rig, r.coverage, r.data.positions
    widths = ", ".join(f"{w:.2f} m at x = {x} m" for x, w in zip(cov.widths_x, cov.y_half_width))
    missed = f" (missed: {cov.missed[:5]})" if cov.missed else ""
    return (
        "## The rig on link 1\n\n"
        f"Two cameras {rig.baseline} m apart along y, centre {tuple(rig.center)} m in link1, pitched down "
        f"{rig.pitch_down_deg} deg. Of the throw plane (y = 0) at x {cov.x_m[0]}-{cov.x_m[1]} m, "
        f"z {cov.z_m[0]}-{cov.z_m[1]} m, {100 * cov.fraction:.1f} % is seen by both cameras {cov.margin_px:.0f} px "
        f"inside the image{missed}; common view half-width (the smaller of z = 0 and z = {cov.z_m[1]} m): {widths}.\n"
        f"Calibration poses (reachable, LED within 60 deg of the rig, both cameras): x {W[:, 0].min():.2f}-"
        f"{W[:, 0].max():.2f} m, y {W[:, 1].min():.2f}-{W[:, 1].max():.2f} m, z {W[:, 2].min():.2f}-"
        f"{W[:, 2].max():.2f} m (link1)."
    )


def _fig4(r: Reproduction) -> str:
    fig4 = r.fig4
    table = format_table(
        ["n", *fig4.methods, "refined / all (paired)"],
        [
            [n, *(float(1e3 * fig4.mean(m)[k]) for m in fig4.methods), float(fig4.relative("refined")[k])]
            for k, n in enumerate(fig4.sizes)
        ],
    )
    head = f"## Fig. 4: mean leave-one-out 3D error (mm), {r.config.draws} draw(s) per size"
    return f"{head}\n\n```\n{table}\n```\n\n{_paper_note(fig4, r.calibration)}".rstrip()


def _designs(r: Reproduction) -> str:
    """The optimal pose spread against a random one: robot runs and ideal-position studies."""
    cfg = r.config
    rows: list[list[object]] = []
    for d, runs in r.robot30.items():
        scores = [sc for _, sc in runs]
        if not runs:  # a quick run makes no robot runs of its own for the random spread
            rows.append(["robot, 30 poses", d, "-", "-", _ratio_text(scores, cfg.quick), ""])
            continue
        own = _mm(np.mean([x.calibration_m for x in scores]), 3)
        rows.append(
            ["robot, 30 poses", d, _mm(np.mean([loo for loo, _ in runs]), 3), own, _ratio_text(scores, cfg.quick), ""]
        )
    for d, v in r.designs.items():
        rows.append(
            [
                f"ideal positions, {cfg.design_seeds} seeds",
                d,
                _mm(np.mean([x.loo_m for x in v]), 3),
                _mm(np.mean([x.calibration_m for x in v]), 3),
                f"{np.mean([x.ratio for x in v]):.3f}",
                f"{r.predicted[d]:.3f}",
            ]
        )
    headers = ["study", "design", "LOO", "calibration's own 3D error", "ratio to true cameras", "predicted ratio"]
    return (
        "## Pose spread: optimal (greedy I-optimal on the DLT's error propagation) against uniform random\n\n"
        + _md_table(headers, rows)
        + "\n\nEach pose averages 10 frames, so the calibration adds little to the 3D error of a single frame; the "
        "calibration's own error (the distance between what the calibrated and the true cameras triangulate from the "
        "same pixels) shows the difference between the spreads best."
    )


def _fig6(r: Reproduction) -> str:
    fig6 = r.fig6
    table = format_table(
        ["angle deg", "stereo mm", "mono mm"],
        [
            [float(a), float(1e3 * s), float(1e3 * m)]
            for a, s, m in zip(fig6.angle_deg, fig6.depth_error("stereo"), fig6.depth_error("mono"))
        ],
    )
    return f"## Fig. 6: depth error in cam0 against the beacon line's angle to the image plane\n\n```\n{table}\n```"


def _files(r: Reproduction) -> str:
    files = "\n".join([*(f"- `{p.name}`" for p in r.files), "- `summary.md` (this file)"])
    timing = ", ".join(f"{k} {v:.1f} s" for k, v in r.timings_s.items())
    return f"## Files\n\n{files}\n\nWall-clock time: {timing}."


def _paper_note(fig4, calibration) -> str:
    """What the `paper` method's curve says, from the numbers (the origin's depth decides it)."""
    if "paper" not in fig4.methods or "refined" not in fig4.methods:
        return ""
    ratio = fig4.mean("paper") / fig4.mean("refined")
    depths = ", ".join(f"{float(c.decompose().t[2]):+.3f} m" for c in calibration.cameras)
    return (
        f"The `paper` method (a34 = 1, unnormalised) errs {np.nanmin(ratio):.2f}-{np.nanmax(ratio):.2f} times as much as "
        f"`refined` over these sizes. It fixes p34, the depth of link1's origin in each camera, to 1; that depth is "
        f"{depths} here (the origin sits behind and below the rig), close enough to the focal plane to matter "
        "with few points (docs/calibration.md, 'Pitfalls'); the normalised methods do not care."
    )
