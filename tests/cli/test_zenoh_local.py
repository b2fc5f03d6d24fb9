"""Zenoh without --zenoh-config stays on this host: a default `track --sim --publish` listens on
loopback only and holds no UDP socket (so it joins no multicast group and sends no multicast: its
own sockets, and `ss` and /proc/net/igmp in a network namespace of its own with a second
interface, where Zenoh's defaults listen on every interface and join 224.0.0.224), and a default
`wiithrow listen` in another process still finds it and receives its frames. Configs
that reach past loopback without authentication are refused (one line, exit 2) unless
--insecure-network."""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys

import pytest

from tests.conftest import wait_for
from tests.helpers.sockets import is_loopback, process_sockets, tree_sockets
from wiithrow.app.cli.main import main
from wiithrow.app.errors import AppError
from wiithrow.app.network.zenoh_session import LOCAL_PORT_ENV, check_exposure, load_config

WIITHROW = [sys.executable, "-m", "wiithrow.app.cli.main"]
COUNT = 300  # the frames the listener takes


def _env() -> dict[str, str]:
    return {**os.environ, "PYTHONUNBUFFERED": "1"}  # (with the suite's $WIITHROW_ZENOH_PORT: conftest)


def _only_loopback(pid: int, what: str) -> list:
    """The sockets of `pid` and its children (`track --publish`'s Zenoh session is its writer
    process's), all TCP on loopback."""
    sockets = tree_sockets(pid)
    assert sockets, f"{what} holds no socket"
    for s in sockets:
        assert s.protocol.startswith("tcp"), f"{what} holds a non-TCP socket: {s}"
        assert is_loopback(s.local[0]), f"{what}: {s}"
        assert s.state == "LISTEN" or is_loopback(s.remote[0]), f"{what}: {s}"
    return sockets


def test_default_track_publish_listens_on_loopback_only_and_a_default_listen_receives_it(zenoh_local_port):
    track = subprocess.Popen(
        WIITHROW
        + ["track", "--sim", "--realtime", "--duration", "10", "--publish", "--rig-name", "local"]
        + ["--wait-subscriber", "120"],  # 10 s: 300 frames reach a listener that starts late on a loaded machine
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        env=_env(),
    )
    listen = None
    try:
        listening = wait_for(
            lambda: [s for s in tree_sockets(track.pid) if s.state == "LISTEN"], 120, "track to listen"
        )
        # The first session on this host holds the local meeting port, on 127.0.0.1 only.
        assert [(s.local, s.protocol) for s in listening] == [(("127.0.0.1", zenoh_local_port), "tcp")]
        _only_loopback(track.pid, "track --publish (waiting)")
        listen = subprocess.Popen(
            # 300 (3 s): the listener must still be connected when its sockets are read after its first
            # frame; the track's first 0.5 s come in one burst (its rig catching up as it starts), so
            # with 50 it had often ended by then (at load 8-9: 1 of 9 runs on main, 5 of 7 with
            # --publish's writer process)
            WIITHROW + ["listen", "wiithrow/local/markers", "--count", str(COUNT), "--duration", "120"],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            env=_env(),
        )
        assert listen.stdout is not None
        first = json.loads(listen.stdout.readline())  # a frame crossed from one process to the other
        assert first["key"] == "wiithrow/local/markers"
        # Both, connected, hold TCP sockets on loopback and nothing else.
        track_sockets = _only_loopback(track.pid, "track --publish (publishing)")
        listen_sockets = _only_loopback(listen.pid, "listen (receiving)")
        assert any(s.state == "ESTAB" for s in track_sockets) and any(s.state == "ESTAB" for s in listen_sockets)
        # The second session listens on a loopback port of its own and connected to the meeting port.
        assert any(s.state == "ESTAB" and s.remote == ("127.0.0.1", zenoh_local_port) for s in listen_sockets)
        # the rest through the reader of the first line: `communicate` reads the pipe's descriptor, and the
        # lines `readline` had buffered beyond the first were lost (a fresh clone's run: 299 of 300, the
        # track's first burst written before the first line was read); listen's --duration bounds the read
        rest = listen.stdout.read()
        err = listen.stderr.read() if listen.stderr is not None else ""
        assert listen.wait(timeout=30) == 0, err[-2000:]
        frames = [first] + [json.loads(line) for line in rest.splitlines()]
        assert len(frames) == COUNT
        seqs = [f["payload"]["seq"] for f in frames]
        # in order, none lost (on failure: who sent the frames around the first break)
        breaks = [i for i in range(1, COUNT) if seqs[i] != seqs[i - 1] + 1]
        around = [j for i in breaks[:1] for j in (i - 1, i)]
        senders = [(j, seqs[j], frames[j]["payload"].get("source"), frames[j]["payload"].get("stream")) for j in around]
        assert seqs == list(range(seqs[0], seqs[0] + COUNT)), senders
        # its 10 s are a loaded machine's margin for the listener's frames: once they came, Ctrl-C
        # ends it (exit 130, its rows kept; 0 if its 10 s were over first)
        track.send_signal(signal.SIGINT)
        _, track_err = track.communicate(timeout=120)
        assert track.returncode in (0, 130), track_err[-2000:]
        assert track.returncode == 0 or "wiithrow track: interrupted; the" in track_err, track_err[-2000:]
    finally:
        for process in (track, listen):
            if process is not None and process.poll() is None:
                process.kill()
                process.wait()


#: Run in a network namespace of its own (unshare: a user and a network namespace, no privilege)
#: with a second interface (a veth pair, 10.9.9.1/24) where Zenoh's defaults would listen and join
#: 224.0.0.224: the namespace's /proc/net/igmp and `ss` then show this one process only.
NAMESPACE_SCRIPT = """
ip link set lo up
ip link add v0 type veth peer name v1 || { echo NO-VETH; exit 0; }
ip addr add 10.9.9.1/24 dev v0 && ip link set v0 up && ip link set v1 up
"$PYTHON" -m wiithrow.app.cli.main track --sim --publish --duration 1 --wait-subscriber 120 >/dev/null 2>track.err &
pid=$!
i=0
while [ $i -lt 1800 ] && ! ss -tlnH | grep -q .; do sleep 0.1; i=$((i + 1)); done
sleep 1
echo ---ss; ss -tuanH
echo ---igmp; cat /proc/net/igmp
kill $pid; wait $pid
"""


@pytest.mark.skipif(not all(shutil.which(c) for c in ("unshare", "ip", "ss")), reason="needs unshare, ip and ss")
def test_default_track_publish_in_a_network_namespace_of_its_own_joins_no_multicast_group(tmp_path):
    probe = subprocess.run(["unshare", "-rn", "true"], capture_output=True, timeout=30)
    if probe.returncode != 0:
        pytest.skip(f"unprivileged network namespaces are not allowed here: {probe.stderr.decode().strip()}")
    done = subprocess.run(
        ["unshare", "-rn", "sh", "-c", NAMESPACE_SCRIPT],
        cwd=tmp_path,
        env={**_env(), "PYTHON": sys.executable},
        capture_output=True,
        text=True,
        timeout=400,
    )
    if "NO-VETH" in done.stdout:
        pytest.skip("no veth interface can be made in the namespace")
    assert "---ss" in done.stdout, done.stdout + done.stderr
    igmp = done.stdout.split("---igmp", 1)[1]
    lines = done.stdout.split("---ss", 1)[1].split("---igmp", 1)[0].strip().splitlines()
    assert lines, f"track opened no socket: {(tmp_path / 'track.err').read_text()[-2000:]}"
    for line in lines:  # netid state recv-q send-q local peer
        fields = line.split()
        assert fields[0] == "tcp", f"not TCP: {line}"
        assert fields[4].rsplit(":", 1)[0] in ("127.0.0.1", "[::ffff:127.0.0.1]"), line
    assert any(line.split()[1] == "LISTEN" for line in lines)
    # 224.0.0.224 is E00000E0 in /proc/net/igmp; 224.0.0.1 (every host joins it) is 010000E0
    assert "E00000E0" not in igmp.upper(), igmp
    assert "010000E0" in igmp  # the table was read


def test_the_local_meeting_port_is_checked(monkeypatch, capsys):
    monkeypatch.setenv(LOCAL_PORT_ENV, "seventy")
    assert main(["listen", "--duration", "0.1"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"${LOCAL_PORT_ENV} must be a TCP port" in err


#: Configurations that reach past loopback without authentication (what each exposes).
UNAUTHENTICATED = {
    # the two-host example the README had: every interface, no authentication
    "every-interface": (
        {"mode": "peer", "listen": {"endpoints": ["tcp/0.0.0.0:7447"]}, "scouting": {"multicast": {"enabled": False}}},
        "listens on tcp/0.0.0.0:7447",
    ),
    # no listen endpoint named: Zenoh's default for a peer, tcp/[::]:0, every interface
    "zenoh-default-listen": ({"mode": "peer", "scouting": {"multicast": {"enabled": False}}}, "listens on tcp/[::]:0"),
    "connect-to-another-host": (
        {"mode": "client", "connect": {"endpoints": ["tcp/192.168.1.10:7447"]}},
        "connects to tcp/192.168.1.10:7447",
    ),
    "multicast-scouting": ({"mode": "peer", "listen": {"endpoints": ["tcp/127.0.0.1:0"]}}, "multicast scouting on"),
}


@pytest.mark.parametrize("name", sorted(UNAUTHENTICATED))
def test_a_config_past_loopback_without_authentication_is_refused_in_one_line(name, tmp_path, capsys):
    config, exposed = UNAUTHENTICATED[name]
    path = tmp_path / f"{name}.json5"
    path.write_text(json.dumps(config))
    for command in (["listen", "--duration", "0.1"], ["track", "--sim", "--duration", "0.1", "--publish"]):
        assert main([*command, "--zenoh-config", str(path)]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1, err
        assert exposed in err and "without authentication" in err and "--insecure-network" in err
    # --insecure-network accepts it, saying what it exposes (checked without opening: it would leave loopback)
    check_exposure(load_config(path), path, insecure_network=True)
    warning = capsys.readouterr().err
    assert warning.count("\n") == 1 and exposed in warning and "anyone on that network" in warning
    with pytest.raises(AppError):
        check_exposure(load_config(path), path, insecure_network=False)


def test_insecure_network_needs_a_config_and_applies_to_serve(capsys):
    assert main(["listen", "--insecure-network", "--duration", "0.1"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--insecure-network does not apply without --zenoh-config" in err
    assert main(["track", "--sim", "--duration", "0.1", "--insecure-network"]) == 2
    assert "--insecure-network does not apply without --publish" in capsys.readouterr().err
    assert main(["serve", "--markers-from", "wiithrow/lab", "--insecure-network", "--port", "0"]) == 2
    assert "--insecure-network does not apply without --zenoh-config" in capsys.readouterr().err


def test_default_sessions_meet_through_the_local_port_and_gossip_and_outlive_its_holder(zenoh_local_port):
    """Sessions without a config (in this process: the same code as in several): the first holds the
    local meeting port, the next ones connect to it and to each other (gossip); when the holder
    closes, the others stay linked and the next session takes the port and meets them."""
    from wiithrow.app.network.zenoh_session import open_session

    def meeting_port_listeners() -> int:
        return sum(
            s.state == "LISTEN" and s.local == ("127.0.0.1", zenoh_local_port) for s in process_sockets(os.getpid())
        )

    def delivered(sender, receiver, key: str) -> list[str]:
        got: list[str] = []
        subscriber = receiver.declare_subscriber(key, lambda s: got.append(s.payload.to_string()))
        try:
            publisher = sender.declare_publisher(key)
            wait_for(lambda: publisher.matching_status.matching, 20, f"a subscriber of {key}")
            for i in range(5):
                publisher.put(f"m{i}")
            wait_for(lambda: len(got) >= 5, 20, f"5 samples on {key}")
            publisher.undeclare()
        finally:
            subscriber.undeclare()
        return got

    holder = open_session(None)
    sessions = [holder]
    try:
        assert meeting_port_listeners() == 1
        second, third = open_session(None), open_session(None)
        sessions += [second, third]
        assert meeting_port_listeners() == 1
        # second and third connected to the holder only; they reach each other directly (gossip)
        wait_for(lambda: str(third.info.zid()) in {str(z) for z in second.info.peers_zid()}, 20, "gossip")
        assert delivered(second, third, "test/gossip") == [f"m{i}" for i in range(5)]
        holder.close()
        sessions.remove(holder)
        assert meeting_port_listeners() == 0
        fourth = open_session(None)
        sessions.append(fourth)
        assert meeting_port_listeners() == 1  # the next session took the port
        wait_for(lambda: len(list(fourth.info.peers_zid())) >= 2, 30, "the others to reconnect to the new holder")
        assert delivered(second, fourth, "test/after") == [f"m{i}" for i in range(5)]
        assert delivered(third, second, "test/still") == [f"m{i}" for i in range(5)]
    finally:
        for session in sessions:
            session.close()


def test_a_zenoh_config_nested_too_deep_is_one_line_before_zenoh_parses_it(tmp_path, capsys):
    """Zenoh's parser recursed into arrays 40,000 deep until the process crashed (exit 139)."""
    deep = tmp_path / "deep.json5"
    deep.write_text('{"listen": {"endpoints": ' + "[" * 50_000 + "]" * 50_000 + "}}")
    assert main(["listen", "--zenoh-config", str(deep), "--count", "1"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "nested deeper than 32 levels" in err, err
    with pytest.raises(AppError, match="no Zenoh configuration is"):
        load_config(deep)
