"""Cyclone DDS's sockets bound to 127.0.0.1 while a loopback domain opens: `loopback_binds()`.

Why: Cyclone DDS (the C library in the `cyclonedds` wheel, 11.0) binds its unicast receive
sockets (a participant's discovery and data ports) to INADDR_ANY whatever its `NetworkInterface`
says (`ddsi_udp_create_conn`: a receive socket is bound "to any"), and no setting changes that
(the upstream issue "Binding to INADDR_ANY even when configured for loopback" is open). So a
domain configured for 127.0.0.1 only still listened on 0.0.0.0:7410/7411, where any host could
send it discovery and data.

How: for the duration of the block, the library's link to libc's `bind` (its slot in libddsc's
global offset table, found by reading the library's ELF relocations) points at `_bind_on_loopback`,
which binds an IPv4 socket asked for 0.0.0.0 to 127.0.0.1 instead (same port) and passes every
other request through; the slot is put back when the block ends.

Multicast: a domain that discovers by multicast on the loopback interface (`LOOPBACK_CONFIG`:
what a ROS 2 Humble node with ROS_LOCALHOST_ONLY=1 listens for) receives on the domain's
multicast ports (`ports.multicast_ports`), where a socket bound to 127.0.0.1 would get nothing.
A wildcard bind of one of the `group_ports` is bound to the group, `MULTICAST_GROUP`, instead: such
a socket receives only datagrams sent to the group, never unicast from any host, and with
IP_MULTICAST_ALL off only those of the memberships it joined itself (Cyclone joins the group on
the configured interface, loopback: what arrives on another interface is not delivered to it). Cyclone creates a domain's
sockets while the domain is created (one set per domain: `ManySocketsMode` single), so
`Ros2Domain` opens its domain and participant inside the block. Peers reach the sockets as before:
the domain advertises 127.0.0.1 (its interface) and every peer on this host sends there.

A library whose slot cannot be found (not ELF, no `bind` relocation) is `LoopbackBindError`: the
caller refuses to open the domain rather than listen on every interface.
"""

from __future__ import annotations

import ctypes
import socket
import struct
import threading
from collections.abc import Collection, Iterator
from contextlib import contextmanager
from pathlib import Path

_SHT_RELA, _SHT_DYNSYM = 4, 11
_PAGE = 4096  # mprotect's unit on every platform this runs on (x86_64, aarch64 Linux)
_PROT_READ, _PROT_WRITE, _PROT_EXEC = 1, 2, 4
#: Cyclone's SPDPMulticastAddress, and its data multicast address ("auto": the same), by default.
MULTICAST_GROUP = "239.255.0.1"
_IP_MULTICAST_ALL = (
    49  # <linux/in.h>: 0 = only the groups this socket joined (default 1: every group any socket joined)
)

#: libc's bind(int, const struct sockaddr *, socklen_t), errno kept (ctypes' per-thread copy).
_BIND = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_int, ctypes.c_void_p, ctypes.c_uint32, use_errno=True)


class LoopbackBindError(RuntimeError):
    """The DDS library's `bind` cannot be redirected (module docstring)."""


def relocation_offset(library: Path, symbol: str) -> int:
    """The offset (from the library's load address) of the slot through which `library` calls
    `symbol`: the `r_offset` of its relocation in a RELA section (`.rela.plt` or `.rela.dyn`).
    LoopbackBindError if the file is not a 64-bit little-endian ELF or has no such relocation."""
    data = library.read_bytes()
    if data[:4] != b"\x7fELF" or data[4] != 2 or data[5] != 1:
        raise LoopbackBindError(f"{library.name} is not a 64-bit little-endian ELF library")
    shoff, shentsize, shnum = struct.unpack_from("<Q", data, 0x28)[0], *struct.unpack_from("<HH", data, 0x3A)
    # (sh_type, sh_offset, sh_size, sh_link, sh_entsize) of every section
    sections = [struct.unpack_from("<4xI16xQQI12xQ", data, shoff + i * shentsize) for i in range(shnum)]
    for sh_type, offset, size, link, entsize in sections:
        if sh_type != _SHT_RELA or sections[link][0] != _SHT_DYNSYM or entsize != 24:
            continue
        _, symtab, _, strtab_index, _ = sections[link]
        strtab = sections[strtab_index][1]
        for r in range(offset, offset + size, entsize):
            r_offset, r_info = struct.unpack_from("<QQ", data, r)
            (st_name,) = struct.unpack_from("<I", data, symtab + (r_info >> 32) * 24)
            end = data.index(b"\0", strtab + st_name)
            if data[strtab + st_name : end] == symbol.encode():
                return int(r_offset)
    raise LoopbackBindError(f"{library.name} has no relocation of {symbol}")


class _DlPhdrInfo(ctypes.Structure):
    _fields_ = [("addr", ctypes.c_size_t), ("name", ctypes.c_char_p)]  # the head of struct dl_phdr_info


_PHDR_CALLBACK = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.POINTER(_DlPhdrInfo), ctypes.c_size_t, ctypes.c_void_p)


def load_bias(library: Path) -> int:
    """Where the dynamic linker loaded `library` in this process (`dl_iterate_phdr`'s dlpi_addr)."""
    target = library.resolve()
    found: list[int] = []

    def visit(info: ctypes._Pointer[_DlPhdrInfo], _size: int, _data: int) -> int:
        name = info.contents.name
        if name and Path(name.decode()).resolve() == target:
            found.append(int(info.contents.addr))
            return 1
        return 0

    ctypes.CDLL(None).dl_iterate_phdr(_PHDR_CALLBACK(visit), None)
    if not found:
        raise LoopbackBindError(f"{library.name} is not loaded in this process")
    return found[0]


def _page_protection(address: int) -> int:
    """The protection of the mapping that holds `address` (/proc/self/maps)."""
    for line in Path("/proc/self/maps").read_text().splitlines():
        span, perms = line.split()[:2]
        start, end = (int(x, 16) for x in span.split("-"))
        if start <= address < end:
            return (
                (_PROT_READ if perms[0] == "r" else 0)
                | (_PROT_WRITE if perms[1] == "w" else 0)
                | (_PROT_EXEC if perms[2] == "x" else 0)
            )
    raise LoopbackBindError(f"address {address:#x} is not mapped")


_libc = ctypes.CDLL(None, use_errno=True)
_libc.mprotect.argtypes = [ctypes.c_void_p, ctypes.c_size_t, ctypes.c_int]
_real_bind = _BIND(("bind", _libc))
_lock = threading.Lock()
#: The ports a redirected bind gave 127.0.0.1 (or the group) instead of 0.0.0.0 (what the tests read).
rebound_ports: list[int] = []
_group_ports: frozenset[int] = frozenset()  # this block's (`loopback_binds`)


def _bind_on_loopback(fd: int, address: int, length: int) -> int:
    family = ctypes.c_uint16.from_address(address).value
    if family == socket.AF_INET and length >= 16 and ctypes.c_uint32.from_address(address + 4).value == 0:
        rebound = (ctypes.c_ubyte * length).from_buffer_copy(ctypes.string_at(address, length))
        port = int.from_bytes(bytes(rebound[2:4]), "big")  # sin_port (kept); sin_addr is bytes 4-7
        target = "127.0.0.1"
        if port in _group_ports:
            target = MULTICAST_GROUP
            only_own = ctypes.c_int(0)
            if _libc.setsockopt(fd, socket.IPPROTO_IP, _IP_MULTICAST_ALL, ctypes.byref(only_own), 4) != 0:
                return -1  # (errno: setsockopt's) a group socket that would hear every group of the host: refused
        rebound[4:8] = list(socket.inet_aton(target))
        rebound_ports.append(port)
        return int(_real_bind(fd, ctypes.addressof(rebound), length))
    return int(_real_bind(fd, address, length))


_hook = _BIND(_bind_on_loopback)  # kept for the life of the process: C holds its address while patched


def _write_slot(slot: int, value: int) -> None:
    page = slot & ~(_PAGE - 1)
    protection = _page_protection(slot)
    if not protection & _PROT_WRITE and _libc.mprotect(page, _PAGE, protection | _PROT_WRITE) != 0:
        raise LoopbackBindError(f"cannot make the bind slot writable (errno {ctypes.get_errno()})")
    try:
        ctypes.c_void_p.from_address(slot).value = value
    finally:
        if not protection & _PROT_WRITE:
            _libc.mprotect(page, _PAGE, protection)


@contextmanager
def loopback_binds(library: Path, group_ports: Collection[int] = ()) -> Iterator[None]:
    """While the block runs, `library`'s binds to 0.0.0.0 (IPv4) bind to 127.0.0.1, or to
    `MULTICAST_GROUP` for a port of `group_ports` (module docstring). One block at a time in a
    process (a lock); LoopbackBindError before the block if the redirection cannot be set up."""
    global _group_ports
    with _lock:
        slot = load_bias(library) + relocation_offset(library, "bind")
        original = ctypes.c_void_p.from_address(slot).value
        _group_ports = frozenset(group_ports)
        _write_slot(slot, ctypes.cast(_hook, ctypes.c_void_p).value or 0)
        try:
            yield
        finally:
            _write_slot(slot, original or 0)
            _group_ports = frozenset()


def cyclone_library() -> Path:
    """The file of the Cyclone DDS C library the `cyclonedds` package loaded (its wheel's, or
    CYCLONEDDS_HOME's)."""
    from cyclonedds.internal import DDS

    return Path(DDS._dll_handle._name)
