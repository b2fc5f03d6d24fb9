"""Who can reach the dashboard: whether an address is this machine's only, and the warning for one
that is not (whoever reaches the port can move the robot)."""

from __future__ import annotations


def is_local_host(host: str) -> bool:
    """True for addresses only this machine can reach."""
    return host in ("127.0.0.1", "localhost", "::1") or host.startswith("127.")


def exposure_warning(host: str, port: int) -> str:
    return (
        f"WARNING: the dashboard listens on {host}:{port}. Anyone who can reach this port can move the "
        "robot (calibrate, track, throw). Use it only on a network you trust."
    )
