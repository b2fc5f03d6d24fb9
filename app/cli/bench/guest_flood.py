"""`wiithrow bench guest-flood`: what guests flooding the dashboard cost its operator.

Set-up: the simulated world in real time with its dashboard refreshing (default limits,
`wiithrow.web.limits`). In a separate process (`python -m wiithrow.app.cli.bench.guest_flood`),
an operator's connection (the token in its handshake) reads everything the server sends, like a
browser, and measures its round trip: a websocket ping answered by the server's event loop, the
loop every client message is read, checked and dispatched on, every `PING_EVERY_S`. First with
no guest (`idle`), then while 4 guest connections (the dashboard's Origin, no token) send as
fast as their sockets take it (connecting again if the server closes one), in turn: a click on a button they may not press, Stop, their
camera, a message nested 2 000 deep (2 KB), a message with an unknown field, each guest also
reading what it is sent.

Figures:
* `idle.p99_ms`, `flood.p99_ms` (and p50, max) of the operator's round trip, and `p99_ratio` =
  flood / idle (goal <= 2). Neither window holds the first `WARM_UP_S` of a connection: viser
  sends a new connection the whole scene (what any viewer costs, a guest's or not), so the
  operator's is measured once it has its scene, the flood once the guests have theirs;
* `rss_growth_peak_mb`: the server process's peak resident memory during the flood minus before
  it (sampled every 50 ms; goal <= 50 MB);
* `server_cpu_share_idle`, `server_cpu_share_flood`: the server process's CPU time per second
  of wall time in each window (the flood's includes the guests' warm-up): what the flood costs,
  less at the mercy of other load on the machine than a p99;
* what the flood did: messages the guests sent, refusals the server counted, Stops it ran, the
  Stop notifications it sent (one per burst: to the guest that pressed, nothing running) and
  those the operator got (none while nothing runs), messages read late (rate limit), the guests'
  own rate.
"""

from __future__ import annotations

import asyncio
import dataclasses
import json
import os
import subprocess
import sys
import threading
import time

import numpy as np

GOAL_P99_RATIO = 2.0
GOAL_RSS_MB = 50.0
GUESTS = 4
PING_EVERY_S = 0.05
#: The operator's first seconds, while it is sent the scene, are not measured.
WARM_UP_S = 2.0
#: After the flood, how long a guest may take to end by itself before it is cancelled (s).
GUEST_END_S = 0.5


def _rss_mb() -> float:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 1e6


class _RssSampler:
    """The largest resident memory seen while running (a thread, every 50 ms)."""

    def __init__(self) -> None:
        self.peak = _rss_mb()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)

    def _run(self) -> None:
        while not self._stop.wait(0.05):
            self.peak = max(self.peak, _rss_mb())

    def __enter__(self) -> _RssSampler:
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        self._thread.join()
        self.peak = max(self.peak, _rss_mb())


def run(quick: bool = False) -> dict:
    from wiithrow.app.session import demo_target_base, simulated_session
    from wiithrow.web.server import Dashboard

    idle_s, flood_s = (2.0, 3.0) if quick else (10.0, 30.0)
    session = simulated_session(seed=0, calibration=None, realtime=True, quiet=True)
    session.set_target(demo_target_base())
    dashboard = Dashboard(session, port=0, derived_figures=False, analysis_process=False)
    dashboard.start()
    limits = dataclasses.asdict(dashboard._gatekeeper.limits)
    figures: dict = {"guests": GUESTS, "idle_s": idle_s, "flood_s": flood_s, "limits": limits}
    try:
        time.sleep(1.0)
        url = dashboard.url.replace("http", "ws", 1)
        proc = subprocess.Popen(
            [sys.executable, "-m", __name__, url, str(idle_s), str(flood_s), dashboard._gatekeeper.stop_uuid or ""],
            stdout=subprocess.PIPE,
            text=True,
            env={**os.environ, "WIITHROW_TOKEN": dashboard.access.token.value},
        )
        assert proc.stdout is not None
        if not proc.stdout.readline():  # {"phase": "idle"}: the operator has its scene
            raise RuntimeError("the bench's clients ended before the idle window")
        cpu0, wall0 = time.process_time(), time.monotonic()
        if not proc.stdout.readline():  # {"phase": "flood"}: the idle window is over
            raise RuntimeError("the bench's clients ended before the flood")
        cpu1, wall1 = time.process_time(), time.monotonic()
        keeper = dashboard._gatekeeper
        refusals0, stops0, notices0 = dict(dashboard.refusals.counts), dashboard.stops, dashboard.stop_notices
        throttled0 = keeper.throttled
        before = _rss_mb()
        with _RssSampler() as rss:
            line = proc.stdout.readline()
        cpu2, wall2 = time.process_time(), time.monotonic()
        figures["server_cpu_share_idle"] = (cpu1 - cpu0) / (wall1 - wall0)
        figures["server_cpu_share_flood"] = (cpu2 - cpu1) / (wall2 - wall1)
        proc.wait(timeout=30)
        clients = json.loads(line)
        figures.update(clients)
        figures["rss_before_mb"] = before
        figures["rss_growth_peak_mb"] = rss.peak - before
        figures["server_refusals"] = {k: v - refusals0.get(k, 0) for k, v in dashboard.refusals.counts.items()}
        figures["server_stops"] = dashboard.stops - stops0
        figures["stop_notifications"] = dashboard.stop_notices - notices0
        figures["server_read_late"] = keeper.throttled - throttled0
    finally:
        session.stop()
        dashboard.close()
        session.close()
    ratio = figures["flood"]["p99_ms"] / figures["idle"]["p99_ms"]
    figures["p99_ratio"] = ratio
    figures["goal_p99_ratio"] = GOAL_P99_RATIO
    figures["goal_rss_mb"] = GOAL_RSS_MB
    figures["goal_met"] = bool(ratio <= GOAL_P99_RATIO and figures["rss_growth_peak_mb"] <= GOAL_RSS_MB)
    return figures


# -- the clients (a separate process: `python -m wiithrow.app.cli.bench.guest_flood WS_URL IDLE_S FLOOD_S STOP`) --


def _summary(rtts: list[float]) -> dict:
    ms = 1e3 * np.asarray(rtts) if rtts else np.array([np.nan])
    return {
        "pings": len(rtts),
        "p50_ms": float(np.percentile(ms, 50)),
        "p99_ms": float(np.percentile(ms, 99)),
        "max_ms": float(ms.max()),
    }


def nested(depth: int) -> bytes:
    """A msgpack map whose first field holds `depth` nested one-element arrays (a byte a level),
    before its `type`: the worst case, a decoder must skip the field to find the type."""
    import msgspec

    encode = msgspec.msgpack.encode
    return b"\x82" + encode("zz") + b"\x91" * depth + b"\x01" + encode("type") + encode("GuiUpdateMessage")


def flood_messages(stop_uuid: str) -> list[bytes]:
    """What each guest sends, in turn."""
    from wiithrow.app.cli.bench import viser_client as vc

    return [
        vc.click("a-button-guests-may-not-press"),
        vc.click(stop_uuid),
        vc.camera_message(),
        nested(2000),
        vc.encode({**vc.CAMERA, "extra": [1, 2, 3]}),
    ]


async def _operator(url: str, stop: asyncio.Event, phase: list[list[float] | None], notifications: list[str]) -> None:
    """The operator's connection: pings every PING_EVERY_S, each round trip appended to the list in
    `phase[0]` (None: the warm-up, not kept); counts the notifications it is sent, by title."""
    import viser
    import websockets
    from websockets.typing import Subprotocol

    from wiithrow.app.cli.bench.viser_client import camera_message, decode_window

    async with websockets.connect(
        url,
        subprotocols=[Subprotocol(f"viser-v{viser.__version__}")],
        max_size=None,
        compression=None,
        additional_headers={"Authorization": f"Bearer {os.environ['WIITHROW_TOKEN']}"},
    ) as ws:
        await ws.send(camera_message())

        async def read() -> None:
            async for data in ws:
                if isinstance(data, bytes) and len(data) >= 16:
                    for m in decode_window(data):
                        if m.get("type") == "NotificationShowMessage":
                            notifications.append(str(m.get("props", {}).get("title")))

        reader = asyncio.create_task(read())
        try:
            while not stop.is_set():
                t0 = time.perf_counter()
                pong = await ws.ping()
                await pong
                kept = phase[0]
                if kept is not None:
                    kept.append(time.perf_counter() - t0)
                await asyncio.sleep(PING_EVERY_S)
        finally:
            reader.cancel()


async def _guest(
    url: str, stop: asyncio.Event, messages: list[bytes], sent: list[int], connected: list[int], k: int
) -> None:
    """One guest: floods, and connects again each time the server closes it (counted in
    `connected[k]`: the count survives the guest being cancelled at the end)."""
    import viser
    import websockets
    from websockets.typing import Subprotocol

    origin = "http://" + url.split("://", 1)[1].rstrip("/")
    i = 0
    while not stop.is_set():
        try:
            async with websockets.connect(
                url,
                subprotocols=[Subprotocol(f"viser-v{viser.__version__}")],
                max_size=None,
                compression=None,
                origin=websockets.Origin(origin),
                close_timeout=1.0,
            ) as ws:
                connected[k] += 1

                async def drain(ws=ws) -> None:
                    async for _ in ws:
                        pass

                reader = asyncio.create_task(drain())
                try:
                    while not stop.is_set():
                        await ws.send(messages[i % len(messages)])
                        sent[k] += 1
                        i += 1
                        if i % 64 == 0:
                            await asyncio.sleep(0)  # let the reader and the operator run
                except asyncio.CancelledError:  # the flood is over (`_clients`): drop the unsent backlog
                    ws.transport.abort()  # (a graceful close would wait for the server to read it all)
                    raise
                finally:
                    reader.cancel()
        except Exception:  # closed by the server, refused (503), or torn down at the end: again
            await asyncio.sleep(0.05)


async def _clients(url: str, idle_s: float, flood_s: float, stop_uuid: str) -> dict:
    stop = asyncio.Event()
    idle: list[float] = []
    flood: list[float] = []
    phase: list[list[float] | None] = [None]
    notifications: list[str] = []
    operator = asyncio.create_task(_operator(url, stop, phase, notifications))
    await asyncio.sleep(WARM_UP_S)  # the initial scene is sent
    print(json.dumps({"phase": "idle"}), flush=True)
    phase[0] = idle
    await asyncio.sleep(idle_s)
    print(json.dumps({"phase": "flood"}), flush=True)
    notifications.clear()
    phase[0] = None
    sent = [0] * GUESTS
    connected = [0] * GUESTS
    messages = flood_messages(stop_uuid)
    guests = [asyncio.create_task(_guest(url, stop, messages, sent, connected, k)) for k in range(GUESTS)]
    t0 = time.monotonic()
    await asyncio.sleep(WARM_UP_S)  # the guests connect and are sent the scene, as any viewer is
    phase[0] = flood
    await asyncio.sleep(flood_s)
    stop.set()
    seconds = time.monotonic() - t0
    # A guest blocked in a send (the server reads a flooding guest at its rate limit) would wait
    # for the server to read its whole backlog, tens of seconds: the flood is over, so it is cut.
    _, blocked = await asyncio.wait(guests, timeout=GUEST_END_S)
    for guest in blocked:
        guest.cancel()
    await asyncio.gather(*guests, return_exceptions=True)
    await operator
    return {
        "idle": _summary(idle),
        "flood": _summary(flood),
        "guest_messages_sent": sum(sent),
        "guest_messages_per_s": sum(sent) / seconds,
        "guest_connections": sum(connected),
        "stop_notifications_to_operator": notifications.count("Stop"),
    }


if __name__ == "__main__":
    result = asyncio.run(_clients(sys.argv[1], float(sys.argv[2]), float(sys.argv[3]), sys.argv[4]))
    print(json.dumps(result), flush=True)
