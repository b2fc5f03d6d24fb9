"""The sockets a process holds, read as `ss -tuanp` reads them: /proc/PID/fd names each socket's
inode, /proc/PID/net/{tcp,tcp6,udp,udp6,raw,raw6} give its protocol, addresses and state.

A multicast group is joined by a socket (IP_ADD_MEMBERSHIP on a UDP socket), so a process with
no UDP or raw socket has joined none and sends no multicast (/proc/net/igmp is the whole network
namespace's, shared with every other process on the machine, so it cannot say which process
joined).
"""

from __future__ import annotations

import ipaddress
import os
import struct
from dataclasses import dataclass

TCP_STATES = {"01": "ESTAB", "02": "SYN-SENT", "06": "TIME-WAIT", "0A": "LISTEN"}


@dataclass(frozen=True)
class Socket:
    protocol: str  # tcp, tcp6, udp, udp6, raw, raw6
    local: tuple[str, int]
    remote: tuple[str, int]
    state: str

    def __str__(self) -> str:
        return f"{self.protocol} {self.state} {self.local[0]}:{self.local[1]} -> {self.remote[0]}:{self.remote[1]}"


def _address(text: str) -> tuple[str, int]:
    """`0100007F:1D1A` (IPv4) or 32 hex digits (IPv6), and the port: the kernel prints each 32-bit
    word of the address as a number in this machine's byte order."""
    host, port = text.split(":")
    packed = b"".join(struct.pack("=I", int(host[i : i + 8], 16)) for i in range(0, len(host), 8))
    return str(ipaddress.ip_address(packed)), int(port, 16)


def process_sockets(pid: int) -> list[Socket]:
    """Every IP socket `pid` holds (none: it has no network socket, or it has ended)."""
    inodes = set()
    try:
        for fd in os.listdir(f"/proc/{pid}/fd"):
            try:
                target = os.readlink(f"/proc/{pid}/fd/{fd}")
            except OSError:
                continue
            if target.startswith("socket:["):
                inodes.add(target[len("socket:[") : -1])
    except FileNotFoundError:
        return []
    found = []
    for protocol in ("tcp", "tcp6", "udp", "udp6", "raw", "raw6"):
        try:
            with open(f"/proc/{pid}/net/{protocol}") as table:
                lines = table.read().splitlines()[1:]
        except FileNotFoundError:
            continue
        for line in lines:
            fields = line.split()
            if fields[9] in inodes:
                state = TCP_STATES.get(fields[3], fields[3]) if protocol.startswith("tcp") else "UNCONN"
                found.append(Socket(protocol, _address(fields[1]), _address(fields[2]), state))
    return found


def descendants(pid: int) -> list[int]:
    """`pid`'s children, theirs, ... (read from each process's /proc/PID/stat: its parent)."""
    parents: dict[int, int] = {}
    for name in os.listdir("/proc"):
        if not name.isdigit():
            continue
        try:
            with open(f"/proc/{name}/stat") as stat:
                fields = stat.read().rsplit(")", 1)[1].split()  # after "pid (comm)": state, ppid, ...
        except (OSError, IndexError):
            continue
        parents[int(name)] = int(fields[1])
    found, frontier = [], [pid]
    while frontier:
        children = [child for child, parent in parents.items() if parent in frontier]
        found += children
        frontier = children
    return found


def tree_sockets(pid: int) -> list[Socket]:
    """Every IP socket `pid` and its descendants hold (a command's writer processes: `--publish`'s
    Zenoh session lives in one)."""
    return [s for each in [pid, *descendants(pid)] for s in process_sockets(each)]


def is_loopback(host: str) -> bool:
    address = ipaddress.ip_address(host)
    if isinstance(address, ipaddress.IPv6Address) and address.ipv4_mapped is not None:
        address = address.ipv4_mapped
    return address.is_loopback
