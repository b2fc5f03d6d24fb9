"""Whether the arm's state is measured at all: `probe_measured`, the check "state measured".

The following checks compare the state with the command; a driver that reports its commands as
its state (an echo) passes them with a tracking error of nothing, whatever the arm does. What a
measured state shows and a copy does not, judged on what the state and slow-motion probes read
(their `Recording`s; nothing moves here):

* while the command moves, a measured position equals one of the trajectory's commanded samples
  bit for bit only where the driver copies it: the fraction of such states is at most
  `bounds.ECHO_FRACTION_MAX`, else the check fails (an echo);
* while the command moves, consecutive new states (each stamped later than the last) carry
  different joints: at most `bounds.REPEATED_FRACTION_MAX` of them the same bit for bit, else a
  warning (the state is stamped when read, not when measured: its age says less than it is);
* at rest, the joints carry some noise: every joint the very same over the state probe's new
  samples (at least `bounds.REST_NOISE_MIN_SAMPLES`) is a warning (a copy of the held command,
  or a braked joint on a coarse encoder).

Which of these a driver may have a reason for is why only the first fails the check; none is
about the host's timing (a late read changes how many states are compared, not what they are).
The independent check, the rig seeing the arm move, is `rig_probe`.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from wiithrow.app.drivercheck import bounds
from wiithrow.app.drivercheck.probes import Recording
from wiithrow.app.drivercheck.report import CheckResult, judged, not_run

#: A commanded joint moves when it is faster than this (rad/s): slower, a copy and a measurement
#: may both sit on the same held value.
MOVING_RAD_S = 1e-3


def moving_states(moving: Recording) -> tuple[np.ndarray, np.ndarray]:
    """The new states' joints (N, nq) while the command moved, and the commanded joints at their
    timestamps (N, nq)."""
    traj = moving.traj
    assert traj is not None  # a recording of a motion
    new = moving.samples.new()
    t_rel = new.t - moving.t0
    during = (t_rel >= 0.0) & (t_rel <= traj.duration)
    q_cmd, dq_cmd, _ = traj.sample(t_rel[during])
    fast = np.max(np.abs(dq_cmd), axis=1) > MOVING_RAD_S if q_cmd.size else np.zeros(0, bool)
    return new.q[during][fast], q_cmd[fast]


def echo_figures(moving: Recording) -> dict[str, Any]:
    """How many moving states equal a commanded sample, and repeat the one before, bit for bit."""
    traj = moving.traj
    assert traj is not None
    q, q_cmd = moving_states(moving)
    commanded = {row.tobytes() for row in np.ascontiguousarray(traj.positions)}
    exact = sum(np.ascontiguousarray(row).tobytes() in commanded for row in q)
    # consecutive states whose command moved between them, the same bit for bit
    changed = np.any(q_cmd[1:] != q_cmd[:-1], axis=1) if len(q) > 1 else np.zeros(0, bool)
    same = np.all(q[1:] == q[:-1], axis=1) if len(q) > 1 else np.zeros(0, bool)
    return {
        "moving_states": len(q),
        "equal_to_command": int(exact),
        "equal_to_command_fraction": exact / len(q) if len(q) else float("nan"),
        "consecutive_pairs": int(changed.sum()),
        "repeated_pairs": int((same & changed).sum()),
        "repeated_fraction": float((same & changed).sum() / changed.sum()) if changed.any() else float("nan"),
    }


def probe_measured(rest: Recording | None, moving: Recording | None) -> CheckResult:
    """Judge the state itself on the state probe's reads (`rest`) and the slow motion's (`moving`),
    as the module docstring says; not run without either."""
    if rest is None and moving is None:
        return not_run("state measured", "neither the state nor the slow motion was read")
    figures: dict[str, Any] = {}
    failures: list[str] = []
    warnings: list[str] = []
    summary: list[str] = []
    if moving is not None:
        figures.update(echo_figures(moving))
        n, exact = figures["moving_states"], figures["equal_to_command"]
        if n == 0:
            failures.append("no new state while the slow motion's command moved: nothing to judge it by")
        elif exact / n > bounds.ECHO_FRACTION_MAX:
            failures.append(
                f"the state equals the command bit for bit in {exact} of {n} states while the arm was "
                f"commanded to move ({100 * exact / n:.0f} % > {100 * bounds.ECHO_FRACTION_MAX:.0f} %): "
                "it echoes its commands instead of measuring the arm"
            )
        else:
            summary.append(f"{exact} of {n} moving states equal to the command")
        repeated = figures["repeated_fraction"]
        if np.isfinite(repeated) and repeated > bounds.REPEATED_FRACTION_MAX:
            warnings.append(
                f"{figures['repeated_pairs']} of {figures['consecutive_pairs']} consecutive states while moving "
                f"repeat the joints of the one before with a later timestamp ({100 * repeated:.0f} %): the state "
                "is stamped when read, not when measured, and is older than its age says"
            )
    if rest is not None:
        new = rest.samples.new()
        spread = np.ptp(new.q, axis=0) if new.t.size else np.zeros(0)
        figures["rest_new_samples"] = int(new.t.size)
        figures["rest_spread_max_rad"] = float(np.max(spread)) if spread.size else float("nan")
        if new.t.size >= bounds.REST_NOISE_MIN_SAMPLES and not np.any(spread > 0.0):
            warnings.append(
                f"no noise at rest: every joint reads the very same value in {new.t.size} samples over "
                f"{bounds.STATE_PROBE_S:g} s (a measured arm jitters by an encoder count at least; is it the held command?)"
            )
        else:
            summary.append(f"at rest the joints spread by up to {figures['rest_spread_max_rad']:.1e} rad")
    limits = {
        "equal_to_command_fraction": {"max": bounds.ECHO_FRACTION_MAX},
        "repeated_fraction": {"max": bounds.REPEATED_FRACTION_MAX, "warn": True},
        "rest_spread_max_rad": {"above": 0.0, "warn": True},
    }
    return judged("state measured", figures, limits, failures, "; ".join(summary) or "measured", warnings)
