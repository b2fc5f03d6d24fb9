"""The UDP ports a DDS domain's participants use on this host, and who holds them:
`taken_ports_message` (the one line of a domain that could not open).

The ports are the RTPS specification's default mapping (section 9.6.1.1), which Cyclone DDS
and every ROS 2 middleware use: for domain d and participant index i,
discovery (unicast) = PB + DG d + d1 + PG i and data (unicast) = PB + DG d + d3 + PG i, with
PB = 7400, DG = 250, PG = 2, d1 = 10, d3 = 11. So domain 0's participant 0 listens on 7410 and
7411, participant 1 on 7412 and 7413 (and every participant of the domain on the multicast ports
PB + DG d + d0 and PB + DG d + d2, d0 = 0, d2 = 1: 7400 and 7401, shared: `multicast_ports`), and the `LOOPBACK_CONFIG`'s automatic index tries
0..`MAX_AUTO_PARTICIPANT_INDEX` (7410-7475 for domain 0) before it gives up. Another domain
is another range of 250 ports: `--ros2-domain` moves away from a taken range.

Who holds a port is read from Linux's tables: /proc/net/udp and udp6 (the socket's inode for
each local port) and /proc/<pid>/fd (which process has that inode open: the processes this user
may read).
"""

from __future__ import annotations

import os
import socket
from pathlib import Path

PORT_BASE, DOMAIN_GAIN, PARTICIPANT_GAIN, DISCOVERY_OFFSET, DATA_OFFSET = 7400, 250, 2, 10, 11
MULTICAST_DISCOVERY_OFFSET, MULTICAST_DATA_OFFSET = 0, 1
#: Cyclone's `MaxAutoParticipantIndex` in `LOOPBACK_CONFIG`: the indices 0..32 that
#: `ParticipantIndex auto` tries (33 participants of one domain on this host).
MAX_AUTO_PARTICIPANT_INDEX = 32
#: Domains suggested instead of a taken one: those whose ports fit the default mapping on Linux (0-101).
SUGGESTED_DOMAINS = range(102)


def participant_ports(domain_id: int, index: int) -> tuple[int, int]:
    """(discovery, data) unicast ports of participant `index` in domain `domain_id`."""
    base = PORT_BASE + DOMAIN_GAIN * domain_id + PARTICIPANT_GAIN * index
    return base + DISCOVERY_OFFSET, base + DATA_OFFSET


def multicast_ports(domain_id: int) -> tuple[int, int]:
    """(discovery, data) multicast ports of domain `domain_id`: every participant's, shared."""
    base = PORT_BASE + DOMAIN_GAIN * domain_id
    return base + MULTICAST_DISCOVERY_OFFSET, base + MULTICAST_DATA_OFFSET


def domain_ports(domain_id: int) -> list[int]:
    """Every port the automatic participant index may take in `domain_id`, in the order tried."""
    return [p for i in range(MAX_AUTO_PARTICIPANT_INDEX + 1) for p in participant_ports(domain_id, i)]


def port_free(port: int) -> bool:
    """Whether a UDP socket can be bound to 127.0.0.1:`port` now (tried, then closed)."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        try:
            s.bind(("127.0.0.1", port))
        except OSError:
            return False
    return True


def port_holders(ports: set[int]) -> dict[int, list[str]]:
    """For each of `ports` bound by a UDP socket on this host, its local address and the process
    that holds it where readable: {port: ['127.0.0.1 by pid 42 (python3)', ...]}."""
    inodes: dict[str, tuple[int, str]] = {}
    for table in ("/proc/net/udp", "/proc/net/udp6"):
        try:
            lines = Path(table).read_text().splitlines()[1:]
        except OSError:
            continue
        for line in lines:
            fields = line.split()
            address, port_hex = fields[1].rsplit(":", 1)
            port = int(port_hex, 16)
            if port in ports:
                inodes[fields[9]] = (port, _address(address))
    owners: dict[str, str] = {}
    for pid in (p for p in os.listdir("/proc") if p.isdigit()) if inodes else ():
        try:
            for fd in os.listdir(f"/proc/{pid}/fd"):
                link = os.readlink(f"/proc/{pid}/fd/{fd}")
                if link.startswith("socket:[") and link[8:-1] in inodes and link[8:-1] not in owners:
                    owners[link[8:-1]] = f"pid {pid} ({Path(f'/proc/{pid}/comm').read_text().strip()})"
        except OSError:  # gone, or not ours to read
            continue
    held: dict[int, list[str]] = {}
    for inode, (port, address) in inodes.items():
        held.setdefault(port, []).append(f"{address} by {owners.get(inode, 'a process this user cannot see')}")
    return held


def _address(hex_address: str) -> str:
    """/proc/net/udp's address (host byte order hex) as text."""
    raw = bytes.fromhex(hex_address)
    if len(raw) == 4:
        return socket.inet_ntop(socket.AF_INET, raw[::-1])
    words = b"".join(raw[i : i + 4][::-1] for i in range(0, 16, 4))
    return f"[{socket.inet_ntop(socket.AF_INET6, words)}]"


def free_domain(avoid: int) -> int | None:
    """The first domain id (of `SUGGESTED_DOMAINS`, not `avoid`) whose participant 0 ports are free."""
    for d in SUGGESTED_DOMAINS:
        if d != avoid and all(port_free(p) for p in participant_ports(d, 0)):
            return d
    return None


def taken_ports_message(domain_id: int) -> str | None:
    """The one line that says why domain `domain_id` could not open when its participant ports are
    all taken (which, by whom, where to move), or None if some are free (another cause)."""
    ports = domain_ports(domain_id)
    taken = [p for p in ports if not port_free(p)]
    indices = range(MAX_AUTO_PARTICIPANT_INDEX + 1)
    if any(not set(participant_ports(domain_id, i)) & set(taken) for i in indices):
        return None  # a participant index is free: something else stopped the domain
    held = port_holders(set(taken))
    owners = sorted({who.split(" by ", 1)[1] for whos in held.values() for who in whos})
    shown = ", ".join(owners[:3]) + (f" and {len(owners) - 3} more" if len(owners) > 3 else "")
    first = held.get(taken[0], [])
    example = f"UDP {first[0].split(' by ')[0]}:{taken[0]}" if first else f"UDP {taken[0]}"
    move = free_domain(domain_id)
    return (
        f"the UDP ports of DDS domain {domain_id} are taken: {len(taken)} of {ports[0]}-{ports[-1]} (participant "
        f"indices 0-{MAX_AUTO_PARTICIPANT_INDEX}, {example} first)"
        + (f", held by {shown}" if owners else "")
        + (
            f"; move with --ros2-domain {move} (its ports are free)"
            if move is not None
            else "; move with --ros2-domain"
        )
    )
