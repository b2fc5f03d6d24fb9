"""The user's secret and the frames' signatures (`wiithrow.app.network.frame_auth`): the secret is
made once, with mode 0600 in a folder of mode 0700, and every process that starts at once reads the
same one; a file others may read, another user's, or one that is not a secret is refused in one
line; a signature holds for its key and payload only, a copy is refused as a replay, and the
memory of signatures is bounded."""

from __future__ import annotations

import os
import stat
import subprocess
import sys

import pytest

from wiithrow.app.errors import AppError
from wiithrow.app.network.frame_auth import (
    REPLAY_WINDOW,
    SECRET_FILE_ENV,
    FrameSigner,
    FrameVerifier,
    load_secret,
    secret_path,
)

KEY = "wiithrow/lab/markers"


def test_the_secret_is_made_once_readable_by_its_user_only(tmp_path, monkeypatch):
    path = tmp_path / "config" / "wiithrow" / "zenoh-secret"
    monkeypatch.setenv(SECRET_FILE_ENV, str(path))
    assert secret_path() == path
    secret = load_secret()
    assert len(secret) == 32 and load_secret() == secret
    assert stat.S_IMODE(path.stat().st_mode) == 0o600
    assert stat.S_IMODE(path.parent.stat().st_mode) == 0o700
    assert [p.name for p in path.parent.iterdir()] == ["zenoh-secret"]  # no temporary left behind


def test_the_default_place_is_the_users_config_folder(monkeypatch, tmp_path):
    monkeypatch.delenv(SECRET_FILE_ENV, raising=False)
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path))
    assert secret_path() == tmp_path / "wiithrow" / "zenoh-secret"


def test_processes_that_start_at_once_agree_on_one_secret(tmp_path):
    path = tmp_path / "shared" / "secret"
    code = "from wiithrow.app.network.frame_auth import load_secret; print(load_secret().hex())"
    env = {**os.environ, SECRET_FILE_ENV: str(path)}
    children = [
        subprocess.Popen([sys.executable, "-c", code], env=env, stdout=subprocess.PIPE, text=True) for _ in range(6)
    ]
    secrets = {child.communicate(timeout=60)[0].strip() for child in children}
    assert len(secrets) == 1 and bytes.fromhex(secrets.pop()) == load_secret(path)


@pytest.mark.parametrize(
    ("mode", "content", "said"),
    [
        (0o644, "ab" * 32 + "\n", "may be read by others (mode 0644): `chmod 600 "),
        (0o640, "ab" * 32 + "\n", "may be read by others (mode 0640)"),
        (0o600, "not a secret\n", "is not 64 hex digits: remove it to make a new one"),
        (0o600, "ab" * 16 + "\n", "is not 64 hex digits"),
        (0o600, "ab" * 2000, "is not 64 hex digits"),
    ],
)
def test_a_secret_file_others_may_read_or_that_is_no_secret_is_refused_in_one_line(tmp_path, mode, content, said):
    path = tmp_path / "secret"
    path.write_text(content)
    path.chmod(mode)
    with pytest.raises(AppError) as refused:
        load_secret(path)
    assert said in str(refused.value) and "\n" not in str(refused.value)
    assert path.read_text() == content  # left as it was


@pytest.mark.skipif(os.getuid() != 0, reason="only root can give a file to another user")
def test_another_users_secret_file_is_refused(tmp_path):
    path = tmp_path / "secret"
    path.write_text("ab" * 32)
    path.chmod(0o600)
    os.chown(path, 4321, -1)
    with pytest.raises(AppError, match="belongs to another user \\(uid 4321\\): make your own"):
        load_secret(path)


def test_a_signature_holds_for_its_key_and_payload_once():
    signer, verifier = FrameSigner(b"k" * 32), FrameVerifier(b"k" * 32)
    payload = b'{"schema": 1, "seq": 7}'
    signature = signer.sign(KEY, payload)
    assert len(signature) == 33 and signature[:1] == b"\x01"
    assert verifier.check(KEY, payload + b" ", signature) == "unauthenticated"  # another payload
    assert verifier.check("wiithrow/lab/throws", payload, signature) == "unauthenticated"  # another key
    assert verifier.check(KEY, payload, None) == "unauthenticated"  # none
    assert verifier.check(KEY, payload, b"\x02" + signature[1:]) == "unauthenticated"  # another version
    assert verifier.check(KEY, payload, FrameSigner(b"x" * 32).sign(KEY, payload)) == "unauthenticated"
    assert verifier.check(KEY, payload, signature) is None  # the real one, once
    assert verifier.check(KEY, payload, signature) == "replayed"


def test_the_memory_of_signatures_is_bounded():
    signer, verifier = FrameSigner(b"k" * 32), FrameVerifier(b"k" * 32)
    first = signer.sign(KEY, b"0")
    assert verifier.check(KEY, b"0", first) is None
    for i in range(1, REPLAY_WINDOW + 1):
        assert verifier.check(KEY, str(i).encode(), signer.sign(KEY, str(i).encode())) is None
    assert len(verifier._seen) == len(verifier._recent) == REPLAY_WINDOW
    # the oldest is forgotten: a copy that old is refused for its seq instead (`source_pin`)
    assert verifier.check(KEY, b"0", first) is None
