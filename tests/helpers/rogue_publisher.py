"""A rogue publisher process: fake marker frames under `wiithrow/<rig>/markers`, in the project's
own message format, as an attacker on the same network would send them (issue 20).

    python -m tests.helpers.rogue_publisher CONFIG RIG KIND[,KIND...] SECONDS [X Y Z]

Kinds (each sent every 10 ms for SECONDS, all from this process's own Zenoh session):
`other_rig` (a well-formed frame naming another rig), `other_source` (the right rig, this
session's own id and stream: a second publisher), `garbage` (the text "garbage"), `nan` (a
visible marker at NaN), `out_of_volume` (a marker behind the rig: the one that swung joint 1 to
3.07 rad), `t1e9:SOURCE:STREAM:SEQ` (ONE frame that copies the real publisher's source and
stream, as a sniffer of unauthenticated traffic would, with that seq and t = 1e9). The fake marker sits at X Y Z in link1 (default
2.0 0.4 0.3: in the rig's view, well off the throw plane). Prints "ready" once its session is
open and "sent N" at the end (also when ended early by SIGTERM).
"""

from __future__ import annotations

import json
import signal
import sys
import time

import zenoh


def _frame(rig: str, seq: int, position: list[float | None], source: str, stream: str, t: float) -> str:
    marker = {"id": 7, "position": position, "velocity": [0.0, 0.0, 0.0], "filtered": position}
    marker.update(visible=True, views=2)
    message = {"schema": 1, "rig": rig, "source": source, "stream": stream, "seq": seq, "t": t, "sent": time.time()}
    message.update(frame="link1", markers=[marker])
    return json.dumps(message)


def main(argv: list[str]) -> int:
    config_file, rig, kinds, seconds = argv[0], argv[1], argv[2].split(","), float(argv[3])
    position = [float(x) for x in argv[4:7]] if len(argv) >= 7 else [2.0, 0.4, 0.3]
    session = zenoh.open(zenoh.Config.from_file(config_file))
    key = f"wiithrow/{rig}/markers"
    source, stream = str(session.zid()), "r0gue0000000000"
    sent = 0
    stopped = []
    signal.signal(signal.SIGTERM, lambda *_: stopped.append(True))
    print("ready", flush=True)
    for kind in [k for k in kinds if k.startswith("t1e9:")]:
        _, real_source, real_stream, real_seq = kind.split(":")
        time.sleep(1.0)  # the session's links are up
        session.put(key, _frame(rig, int(real_seq), [2.0, 0.4, 0.3], real_source, real_stream, 1e9))
        sent += 1
        kinds = [k for k in kinds if k != kind]
    end = time.monotonic() + seconds if kinds else 0.0
    seq = 0
    while time.monotonic() < end and not stopped:
        t = time.monotonic()
        for kind in kinds:
            if kind == "other_rig":
                payload = _frame("other", seq, position, source, stream, t)
            elif kind == "other_source":
                payload = _frame(rig, seq, position, source, stream, t)
            elif kind == "garbage":
                payload = "garbage"
            elif kind == "nan":
                payload = _frame(rig, seq, [float("nan"), 0.0, 0.3], source, stream, t)
            elif kind == "out_of_volume":
                payload = _frame(rig, seq, [-1.0, 0.07, 0.3], source, stream, t)
            else:
                raise SystemExit(f"unknown kind {kind!r}")
            session.put(key, payload)
            sent += 1
        seq += 1
        time.sleep(0.01)
    print(f"sent {sent}", flush=True)
    session.close()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
