"""The real publisher of the rogue tests, in a process of its own: one tracked frame every 10 ms
with one visible marker at X Y Z (link1), put by the project's own `RigPublisher` (what `--publish`'s
writer process runs), as a tracking host would send them.

    python -m tests.helpers.steady_publisher CONFIG RIG SECONDS [X Y Z]

CONFIG: a Zenoh configuration file, or `local`: this host's local meeting ($WIITHROW_ZENOH_PORT).

Each frame is stamped with this process's clock (seconds since it started, as a tracker stamps its
frames); after a SIGSTOP it goes on where it stopped, with the next seq (no catch-up burst). It
prints "ready SOURCE STREAM" once a subscriber of the markers is known, and at the end (SECONDS
passed, or SIGTERM) "sent N LAST_SEQ".
"""

from __future__ import annotations

import signal
import sys
import time

import numpy as np

from wiithrow.app.channels.zenoh_sink import RigPublisher
from wiithrow.app.network.zenoh_session import open_session
from wiithrow.vision.tracked_frame import TrackedFrame

PERIOD_S = 0.01


def frame(t: float, position: list[float]) -> TrackedFrame:
    p = np.array([position], dtype=float)
    return TrackedFrame(t, np.array([0]), p, np.zeros((1, 3)), p, np.array([True]), np.array([2]))


def main(argv: list[str]) -> int:
    config_file, rig, seconds = argv[0], argv[1], float(argv[2])
    position = [float(x) for x in argv[3:6]] if len(argv) >= 6 else [2.0, 0.0, 0.3]
    session = open_session(None if config_file == "local" else config_file)
    publisher = RigPublisher(session, rig, ["cam0", "cam1"], "link1")
    stopped: list[bool] = []
    signal.signal(signal.SIGTERM, lambda *_: stopped.append(True))
    if not publisher.wait_for_subscribers(30.0):
        print("no subscriber", flush=True)
        return 1
    print(f"ready {publisher.sender.source} {publisher.sender.stream}", flush=True)
    start = time.monotonic()
    end = start + seconds
    while not stopped and time.monotonic() < end:
        publisher.publish_markers(frame(time.monotonic() - start, position))
        time.sleep(PERIOD_S)
    print(f"sent {publisher.markers_sent} {publisher.markers_sent - 1}", flush=True)
    publisher.close()
    session.close()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
