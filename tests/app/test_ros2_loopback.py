"""ROS 2 on this host's loopback only: every UDP socket of the writer process and of an in-process
domain is bound to 127.0.0.1, or, on the domain's two multicast ports, to the multicast group
(receiving only what is sent to the group, and only the memberships it joined: IP_MULTICAST_ALL
off) (Linux's /proc tables, as `ss -ulpn` reads them), and a domain whose ports another process
holds is one line that names the ports, the holder and where to move."""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import time
import uuid
from pathlib import Path

import pytest

from tests.helpers.command_lines import after_opening
from wiithrow.app.channels.ros2_sink import Ros2ProcessPublisher
from wiithrow.app.errors import AppError
from wiithrow.app.ros2 import ports
from wiithrow.app.ros2.domain import Ros2Domain
from wiithrow.app.ros2.loopback_bind import MULTICAST_GROUP
from wiithrow.clock import SimClock

ROOT = Path(__file__).resolve().parents[2]
LOOPBACK = "127.0.0.1"
IP_MULTICAST_ALL = 49  # <linux/in.h>


def _domain(offset: int = 0) -> int:
    """A domain id of this test run's own (other tests, other people's ROS 2 on this host)."""
    return 120 + (os.getpid() + offset) % 100


def _udp_sockets(pid: int) -> list[tuple[str, int]]:
    """(local address, port) of every UDP socket process `pid` has open."""
    inodes = set()
    for fd in os.listdir(f"/proc/{pid}/fd"):
        try:
            link = os.readlink(f"/proc/{pid}/fd/{fd}")
        except OSError:
            continue
        if link.startswith("socket:["):
            inodes.add(link[8:-1])
    found = []
    for table in ("/proc/net/udp", "/proc/net/udp6"):
        for line in Path(table).read_text().splitlines()[1:]:
            fields = line.split()
            if fields[9] in inodes:
                address, port = fields[1].rsplit(":", 1)
                found.append((ports._address(address), int(port, 16)))
    return found


def test_the_writer_process_listens_on_loopback_only_and_a_reader_still_matches():
    domain = _domain()
    namespace = f"/t{uuid.uuid4().hex[:8]}"
    publisher = Ros2ProcessPublisher(domain, ["wiimote0"], "link1", clock=SimClock(), namespace=namespace)
    reader = subprocess.Popen(  # a reader of the shipped IDL's types, its Cyclone left as it is (0.0.0.0)
        [sys.executable, "-m", "tests.helpers.ros2_subscriber", str(domain), namespace, "wiimote0", "30"],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=ROOT,
    )
    try:
        sockets = _udp_sockets(publisher.process.pid)
        disc, data = ports.participant_ports(domain, 0)
        assert {disc, data} <= {port for _, port in sockets}, sockets  # the first participant's ports
        assert sockets and all(_on_loopback(domain, *s) for s in sockets), sockets
        assert publisher.wait_for_subscribers(30.0)  # discovery and matching over loopback still work
    finally:
        publisher.close()
        reader.kill()
        reader.communicate()


def _on_loopback(domain: int, address: str, port: int) -> bool:
    """127.0.0.1, or the multicast group on one of the domain's multicast ports."""
    return address == LOOPBACK or (address == MULTICAST_GROUP and port in ports.multicast_ports(domain))


def _multicast_all(port: int) -> list[int]:
    """IP_MULTICAST_ALL of each of this process's UDP sockets bound to the group on `port`."""
    found = []
    for fd in map(int, os.listdir("/proc/self/fd")):
        try:
            with socket.socket(fileno=os.dup(fd)) as s:
                if (
                    s.type == socket.SOCK_DGRAM
                    and s.family == socket.AF_INET
                    and s.getsockname() == (MULTICAST_GROUP, port)
                ):
                    found.append(s.getsockopt(socket.IPPROTO_IP, IP_MULTICAST_ALL))
        except OSError:  # not a socket
            continue
    return found


def test_an_in_process_domain_listens_on_loopback_only():
    before = set(_udp_sockets(os.getpid()))
    domain_id = _domain(1)
    domain = Ros2Domain(domain_id)
    try:
        opened = set(_udp_sockets(os.getpid())) - before
        assert len(opened) >= 5, opened  # unicast discovery and data, transmit, multicast discovery and data
        assert all(_on_loopback(domain_id, *s) for s in opened), opened
        group = {port for address, port in opened if address == MULTICAST_GROUP}
        assert group == set(ports.multicast_ports(domain_id)), opened
        assert [_multicast_all(port) for port in sorted(group)] == [[0], [0]]  # only its own memberships
    finally:
        domain.close()


def _hold(domain: int, address: str) -> subprocess.Popen[str]:
    """A process that binds every port the automatic participant index of `domain` would take."""
    code = (
        "import socket, sys, time\n"
        f"held = [socket.socket(socket.AF_INET, socket.SOCK_DGRAM) for _ in {ports.domain_ports(domain)}]\n"
        f"for s, p in zip(held, {ports.domain_ports(domain)}): s.bind(({address!r}, p))\n"
        "print('holding', flush=True)\n"
        "sys.stdin.read()\n"
    )
    child = subprocess.Popen([sys.executable, "-c", code], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    assert child.stdout is not None and child.stdout.readline().strip() == "holding"
    return child


@pytest.mark.parametrize("address", ["127.0.0.1", "0.0.0.0"])
def test_taken_dds_ports_are_one_line_that_names_the_ports_the_holder_and_where_to_move(capfd, address):
    domain = _domain(2)
    holder = _hold(domain, address)
    try:
        with pytest.raises(AppError) as refused:
            Ros2Domain(domain)
        in_process = capfd.readouterr()
        started = time.monotonic()
        command = subprocess.run(
            [str(Path(sys.executable).with_name("wiithrow")), "track", "--sim", "--duration", "0.5", "--ros2"]
            + ["--ros2-domain", str(domain)],
            capture_output=True,
            text=True,
            cwd=ROOT,
            timeout=120,
        )
    finally:
        holder.communicate("")
    first, last = ports.participant_ports(domain, 0)[0], ports.domain_ports(domain)[-1]
    message = str(refused.value)
    assert "\n" not in message and in_process.err == ""  # Cyclone's own line is not printed
    for needle in (f"{first}-{last}", f"UDP {address}:{first}", f"pid {holder.pid} (python", "--ros2-domain "):
        assert needle in message, message
    assert command.returncode == 2, command.stderr
    lines = command.stderr.strip().splitlines()
    assert "Traceback" not in command.stderr and "Failed to find" not in command.stderr, command.stderr
    assert lines[-1].startswith("wiithrow track: ROS 2: ") and f"pid {holder.pid}" in lines[-1], lines
    assert after_opening(lines) == lines[-1:], lines  # the run's opening, then one line
    print(f"track --ros2 refused in {time.monotonic() - started:.1f} s: {lines[-1]}")
