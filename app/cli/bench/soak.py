"""`wiithrow bench soak [--minutes N] --json`: does the dashboard's process stay within bounds when it
runs for hours?

Set-up: the demo world in real time with its dashboard, as `wiithrow demo` runs it (the target in
front of the arm, the robot-driven calibration of 30 poses started at once), and one websocket
client in another process that reads every window (a browser, minus the rendering) and is the
operator: once a minute the bench moves the simulated target a little (seeded) and tells the
client to click Track target, Preview throw, Throw and Throw now, each once its button is enabled,
through its own controls and the confirmation, as a person would.

Figures: resident memory (RSS, MB) at the start (the dashboard up, before the calibration), after
the warm-up (`warmup_min`: a third of the run, at most 5 minutes: the calibration, the compiled
kernels, the first throws), and at the end; `rss_slope_mb_per_h`, the least-squares slope of RSS
sampled every 10 s after the warm-up (and RSS minute by minute); the throws done and missed; and what the bounded stores hold
at the end (viser's persistent message buffer, the session's throw history, the refusal log).
Goal: a slope <= 10 MB/h with the client connected (`goal_met`).
"""

from __future__ import annotations

import asyncio
import json
import os
import sys
import threading
import time

import numpy as np

from wiithrow.app.cli.bench.dashboard import connect_as_operator, websocket_clients

GOAL_MB_PER_H = 10.0
SAMPLE_S = 10.0
THROW_PERIOD_S = 60.0


def rss_mb() -> float:
    """This process's resident memory (Linux: /proc/self/statm)."""
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 1e6


def slope_mb_per_h(t_s: np.ndarray, rss: np.ndarray) -> float:
    """Least-squares slope of RSS against time, MB per hour (NaN with fewer than 3 samples)."""
    if len(t_s) < 3:
        return float("nan")
    return float(np.polyfit(t_s / 3600.0, rss, 1)[0])


class _Operator:
    """The client process, told what to click on its stdin, answering on its stdout."""

    def __init__(self, dashboard) -> None:
        self.proc = websocket_clients("wiithrow.app.cli.bench.soak", dashboard)
        self._lock = threading.Lock()

    def click(self, label: str, timeout_s: float = 60.0) -> bool:
        with self._lock:
            assert self.proc.stdin is not None and self.proc.stdout is not None
            self.proc.stdin.write(f"{timeout_s} {label}\n")
            self.proc.stdin.flush()
            return self.proc.stdout.readline().strip() == "clicked"

    def close(self) -> dict:
        try:
            out, _ = self.proc.communicate(input="stop\n", timeout=20)
            return json.loads(out.strip().splitlines()[-1])
        except (ValueError, IndexError, OSError):
            self.proc.kill()
            return {}


def _wait(condition, timeout_s: float) -> bool:
    end = time.monotonic() + timeout_s
    while not condition():
        if time.monotonic() > end:
            return False
        time.sleep(0.1)
    return True


def _throw_once(session, operator: _Operator) -> str:
    """One operator's throw through the dashboard; "" if it landed, else what went wrong."""
    if not _wait(lambda: not session.busy, 120.0):
        return "busy"
    before = session.alignment
    if not operator.click("Track target"):
        return "Track target not clickable"
    _wait(lambda: session.busy or session.alignment is not before, 10.0)
    if not _wait(lambda: not session.busy, 60.0) or session.alignment is None or not session.alignment.converged:
        return "not aligned"
    if not operator.click("Preview throw") or not _wait(lambda: session.preview is not None and not session.busy, 30.0):
        return "no preview"
    count = len(session.history)
    if not operator.click("Throw") or not operator.click("Throw now", 20.0):
        return "no confirmation"
    if not _wait(lambda: len(session.history) > count and not session.busy, 60.0):
        return "no throw"
    return ""


def run(quick: bool = False, minutes: float = 30.0) -> dict:
    from wiithrow.app.session import demo_target_base, simulated_session
    from wiithrow.web.server import Dashboard

    minutes = 2.0 if quick else float(minutes)
    warmup_min = min(5.0, minutes / 3.0)
    rng = np.random.default_rng(0)
    session = simulated_session(seed=0, calibration=None, realtime=True, quiet=True)
    target = demo_target_base()
    session.set_target(target)
    dashboard = Dashboard(session, port=0)
    dashboard.start()
    operator = _Operator(dashboard)
    t0 = time.monotonic()
    samples: list[tuple[float, float]] = [(0.0, rss_mb())]
    figures: dict = {"minutes": minutes, "warmup_min": warmup_min, "goal_mb_per_h": GOAL_MB_PER_H}
    throws, missed = 0, 0
    reasons: dict[str, int] = {}
    try:
        _wait(lambda: len(dashboard.server.get_clients()) == 1, 60.0)
        dashboard.start_calibration(30)
        next_throw = THROW_PERIOD_S
        next_sample = SAMPLE_S
        while (now := time.monotonic() - t0) < 60.0 * minutes:
            if now >= next_sample:
                samples.append((now, rss_mb()))
                next_sample += SAMPLE_S
            if now >= next_throw and session.calibration_result is not None and not session.busy:
                session.set_target(target + rng.uniform([-0.05, -0.05, 0.0], [0.05, 0.05, 0.0]))
                why = _throw_once(session, operator)
                throws, missed = throws + (not why), missed + bool(why)
                if why:
                    reasons[why] = reasons.get(why, 0) + 1
                next_throw = max(next_throw + THROW_PERIOD_S, time.monotonic() - t0)
            time.sleep(0.2)
        samples.append((time.monotonic() - t0, rss_mb()))
        t, rss = np.array(samples).T
        after = t >= 60.0 * warmup_min
        figures.update(
            rss_start_mb=float(rss[0]),
            rss_after_warmup_mb=float(rss[after][0]) if after.any() else float("nan"),
            rss_end_mb=float(rss[-1]),
            rss_max_mb=float(rss.max()),
            rss_slope_mb_per_h=slope_mb_per_h(t[after], rss[after]),
            rss_by_minute_mb=[round(float(r), 1) for r in rss[:: int(60 / SAMPLE_S)]],
            samples=len(t),
            throws=throws,
            throws_missed=missed,
            missed_because=reasons,
            clients=len(dashboard.server.get_clients()),
            held_at_end=_held(dashboard),
        )
    finally:
        session.stop()
        dashboard.runner.join(timeout=10.0)
        figures["client"] = operator.close()
        dashboard.close()
        session.close()
    slope = figures.get("rss_slope_mb_per_h", float("nan"))
    figures["goal_met"] = bool(np.isfinite(slope) and slope <= GOAL_MB_PER_H and figures.get("clients") == 1)
    return figures


def _held(dashboard) -> dict:
    """What the bounded stores hold (viser's buffer through a private attribute: -1 if it moved)."""
    buffer = getattr(getattr(dashboard.server, "_websock_server", None), "_broadcast_buffer", None)
    return {
        "viser_persistent_messages": len(buffer.message_from_id) if buffer is not None else -1,
        "session_history": len(dashboard.session.history),
        "refusals_kept": len(dashboard.refusals.recent),
        "rig_tracked_frames": len(dashboard.session.world.rig.tracked_since(-np.inf)),
    }


# -- the operator's client (a separate process: `python -m wiithrow.app.cli.bench.soak WS_URL`) -----------------


async def _operator(url: str) -> dict:
    from wiithrow.app.cli.bench.viser_client import Buttons, camera_message, click

    buttons = Buttons()
    received = 0
    loop = asyncio.get_running_loop()
    lines: asyncio.Queue[str] = asyncio.Queue()
    loop.add_reader(sys.stdin.fileno(), lambda: lines.put_nowait(sys.stdin.readline()))
    t0 = time.monotonic()
    async with connect_as_operator(url) as ws:
        await ws.send(camera_message())

        async def read() -> None:
            nonlocal received
            async for message in ws:
                assert isinstance(message, bytes)
                received += len(message)
                buttons.read(message)

        reader = asyncio.create_task(read())
        while (line := (await lines.get()).strip()) not in ("stop", ""):
            timeout, label = line.split(" ", 1)
            end = time.monotonic() + float(timeout)
            while not buttons.enabled(label) and time.monotonic() < end:
                await asyncio.sleep(0.05)
            if buttons.enabled(label):
                await ws.send(click(buttons.uuid[label]))
                print("clicked", flush=True)
            else:
                print("not enabled", flush=True)
        reader.cancel()
    return {"kB_per_s": received / (time.monotonic() - t0) / 1e3}


if __name__ == "__main__":
    print(json.dumps(asyncio.run(_operator(sys.argv[1]))), flush=True)
