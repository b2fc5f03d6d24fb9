"""A rogue publisher process: fake marker frames under `wiithrow/<rig>/markers`, in the project's
own message format, as an attacker on the same network (or the same machine) would send them.

    python -m tests.helpers.rogue_publisher [--signed] CONFIG RIG KIND[,KIND...] SECONDS [X Y Z]

CONFIG: a Zenoh configuration file, or `local`: this host's local meeting (`open_session(None)`,
on $WIITHROW_ZENOH_PORT), where every session links to every other (a sniffer sees all).

Kinds (each sent every 10 ms for SECONDS, all from this process's own Zenoh session):
`other_rig` (a well-formed frame naming another rig), `other_source` (the right rig, this
session's own id and stream: a second publisher), `garbage` (the text "garbage N"), `nan` (a
visible marker at NaN), `out_of_volume` (a marker behind the rig: the one that swung joint 1 to
3.07 rad), `t1e9:SOURCE:STREAM:SEQ` (ONE frame that copies the real publisher's source and
stream, as a sniffer of unauthenticated traffic would, with that seq and t = 1e9).

Kinds that read the real publisher's frames first (a sniffer on the meeting), for SECONDS:
`copy_ids` (once a second, a frame that copies the newest real frame's source and stream, with a
seq 5 above it and a t 50 ms after it: a frame that follows, with the fake marker), `replay`
(every real frame put again, its payload and attachment byte for byte, as soon as it came).

`flood:RATE`: RATE frames a second, each of 16 visible markers in the rig's view (the costliest
frame to check), under this session's own ids (a flood of the issue's kind).

The fake marker sits at X Y Z in link1 (default 2.0 0.4 0.3: in the rig's view, well off the throw
plane). With `--signed`, every frame carries a valid signature made with this user's secret (a
process of the same user: `wiithrow.app.network.frame_auth`); without it, none. Prints "ready"
once its session is open and "sent N" at the end (also when ended early by SIGTERM); a flood
also its rate, "sent N in S s".
"""

from __future__ import annotations

import json
import signal
import sys
import threading
import time
from collections import deque
from typing import Any

import zenoh


def _frame(rig: str, seq: int, position: list[float | None], source: str, stream: str, t: float) -> str:
    marker = {"id": 7, "position": position, "velocity": [0.0, 0.0, 0.0], "filtered": position}
    marker.update(visible=True, views=2)
    message = {"schema": 1, "rig": rig, "source": source, "stream": stream, "seq": seq, "t": t, "sent": time.time()}
    message.update(frame="link1", markers=[marker])
    return json.dumps(message)


def _flood_frame(rig: str, seq: int, source: str, stream: str) -> str:
    markers = []
    for i in range(16):
        p = [2.0, -0.3 + 0.04 * i, 0.3]
        markers.append(
            {"id": i, "position": p, "velocity": [0.0, 0.0, 0.0], "filtered": p, "visible": True, "views": 2}
        )
    message = {"schema": 1, "rig": rig, "source": source, "stream": stream, "seq": seq, "t": seq * 1e-4}
    message.update(sent=time.time(), frame="link1", markers=markers)
    return json.dumps(message)


class _Sniffer:
    """The real publisher's frames as they come (payload and attachment bytes)."""

    def __init__(self, session: Any, key: str) -> None:
        self.samples: deque[tuple[bytes, bytes | None]] = deque(maxlen=10_000)
        self.newest: dict[str, Any] | None = None
        self._lock = threading.Lock()
        self._subscriber = session.declare_subscriber(key, self._on_sample)

    def _on_sample(self, sample: Any) -> None:
        payload = sample.payload.to_bytes()
        attachment = sample.attachment.to_bytes() if sample.attachment is not None else None
        with self._lock:
            self.samples.append((payload, attachment))
            try:
                self.newest = json.loads(payload)
            except ValueError:
                pass

    def take(self) -> list[tuple[bytes, bytes | None]]:
        with self._lock:
            out = list(self.samples)
            self.samples.clear()
        return out


def main(argv: list[str]) -> int:
    signed = argv[:1] == ["--signed"]
    if signed:
        argv = argv[1:]
    config_file, rig, kinds, seconds = argv[0], argv[1], argv[2].split(","), float(argv[3])
    position = [float(x) for x in argv[4:7]] if len(argv) >= 7 else [2.0, 0.4, 0.3]
    if config_file == "local":
        from wiithrow.app.network.zenoh_session import open_session

        session = open_session(None)
    else:
        session = zenoh.open(zenoh.Config.from_file(config_file))
    key = f"wiithrow/{rig}/markers"
    sign = None
    if signed:
        from wiithrow.app.network.frame_auth import FrameSigner

        sign = FrameSigner.for_this_user().sign
    remote = zenoh.Locality.REMOTE  # never to this session's own subscriber

    def put(payload: str | bytes, attachment: bytes | None = None) -> None:
        data = payload.encode() if isinstance(payload, str) else payload
        if sign is not None and attachment is None:
            attachment = sign(key, data)
        session.put(key, data, attachment=attachment, allowed_destination=remote)

    source, stream = str(session.zid()), "r0gue0000000000"
    sent = 0
    stopped = []
    signal.signal(signal.SIGTERM, lambda *_: stopped.append(True))
    sniffer = _Sniffer(session, key) if {"copy_ids", "replay"} & set(kinds) else None
    print("ready", flush=True)
    for kind in [k for k in kinds if k.startswith("t1e9:")]:
        _, real_source, real_stream, real_seq = kind.split(":")
        time.sleep(1.0)  # the session's links are up
        put(_frame(rig, int(real_seq), [2.0, 0.4, 0.3], real_source, real_stream, 1e9))
        sent += 1
        kinds = [k for k in kinds if k != kind]
    flood = [k for k in kinds if k.startswith("flood:")]
    if flood:
        rate = float(flood[0].split(":")[1])
        payloads = [_flood_frame(rig, seq, source, "f100d000000000").encode() for seq in range(1000)]
        start = time.monotonic()
        end = start + seconds
        while not stopped and (now := time.monotonic()) < end:
            due = int((now - start) * rate)
            while sent < due:
                put(payloads[sent % len(payloads)])
                sent += 1
            time.sleep(0.0005)
        print(f"sent {sent} in {time.monotonic() - start:.2f} s", flush=True)
        session.close()
        return 0
    end = time.monotonic() + seconds if kinds else 0.0
    seq = 0
    last_copy = time.monotonic()
    while time.monotonic() < end and not stopped:
        t = time.monotonic()
        for kind in kinds:
            if kind == "copy_ids":
                assert sniffer is not None
                newest = sniffer.newest
                if newest is not None and t - last_copy >= 1.0:
                    last_copy = t
                    copied = _frame(
                        rig, newest["seq"] + 5, position, newest["source"], newest["stream"], newest["t"] + 0.05
                    )
                    put(copied)
                    sent += 1
                continue
            if kind == "replay":
                assert sniffer is not None
                for payload, attachment in sniffer.take():
                    session.put(key, payload, attachment=attachment, allowed_destination=remote)
                    sent += 1
                continue
            if kind == "other_rig":
                payload = _frame("other", seq, position, source, stream, t)
            elif kind == "other_source":
                payload = _frame(rig, seq, position, source, stream, t)
            elif kind == "garbage":
                payload = f"garbage {seq}"  # (each its own: a signed copy of one would be a replay)
            elif kind == "nan":
                payload = _frame(rig, seq, [float("nan"), 0.0, 0.3], source, stream, t)
            elif kind == "out_of_volume":
                payload = _frame(rig, seq, [-1.0, 0.07, 0.3], source, stream, t)
            else:
                raise SystemExit(f"unknown kind {kind!r}")
            put(payload)
            sent += 1
        seq += 1
        time.sleep(0.01)
    print(f"sent {sent}", flush=True)
    session.close()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
