"""`wiithrow listen [KEYEXPR]`: print what arrives over Zenoh, one JSON line per sample.

    wiithrow listen                                   everything under wiithrow/ (wiithrow/**)
    wiithrow listen wiithrow/rig/markers --count 100  the first 100 marker frames of rig `rig`
    wiithrow listen --duration 10 --zenoh-config router.json5

Each line: {"key": the sample's key, "received": Unix time it arrived (s), "payload": the payload
as JSON (what `track --publish`, `demo --publish` and `serve --publish` send: docs/integrations/zenoh.md), or as text when it is not JSON (or nested too deep to read)}. It ends after --count
samples, after --duration seconds or on Ctrl-C (exit 130), and says on stderr how many samples it
printed; standard output on a full disk ends it with one line saying how many went out
(`wiithrow.app.cli.row_output`), exit status 2. This host's loopback only (what other wiithrow
processes here publish) unless --zenoh-config gives a Zenoh configuration; a bad one, one that
reaches past loopback without authentication (without --insecure-network), or a bad key
expression, is one line and exit 2.
"""

from __future__ import annotations

import argparse
import sys
import time

from wiithrow.app.cli.arguments import positive_float, positive_int
from wiithrow.app.cli.publishing import check_zenoh_config_arguments, open_zenoh
from wiithrow.app.cli.row_output import StdoutRows
from wiithrow.app.network.messages import PREFIX
from wiithrow.app.network.subscriber import Subscription, key_expression
from wiithrow.app.network.zenoh_session import add_zenoh_config_arguments
from wiithrow.vision.files import dumps_strict

NAME = "listen"
HELP = "print what arrives over Zenoh (what --publish sends) as JSON lines"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "keyexpr", nargs="?", default=f"{PREFIX}/**", help=f"Zenoh key expression (default: {PREFIX}/**)"
    )
    parser.add_argument("--count", type=positive_int, default=None, help="stop after N samples")
    parser.add_argument("--duration", type=positive_float, default=None, help="stop after S seconds")
    add_zenoh_config_arguments(parser)


def run(args: argparse.Namespace) -> int:
    check_zenoh_config_arguments(args)
    keyexpr = key_expression(args.keyexpr)
    zenoh_session = open_zenoh(args)
    printed = 0
    out = StdoutRows()
    try:
        subscription = Subscription(zenoh_session, keyexpr)
        end = None if args.duration is None else time.monotonic() + args.duration
        while args.count is None or printed < args.count:
            wait = 0.5 if end is None else end - time.monotonic()
            if wait <= 0:
                break
            sample = subscription.get(min(wait, 0.5))
            if sample is None:
                continue
            line = {"key": sample.key, "received": sample.received, "payload": sample.decode()}
            out.write(dumps_strict(line) + "\n")
            out.flush()
            printed += 1
        subscription.close()
    except KeyboardInterrupt:
        print(f"wiithrow listen: interrupted after {printed} samples", file=sys.stderr)
        return 130
    finally:
        zenoh_session.close()
    print(f"wiithrow listen: {printed} samples on {keyexpr}", file=sys.stderr)
    return 0
