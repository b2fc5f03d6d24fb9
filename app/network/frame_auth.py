"""Who may publish the markers that move the arm: every frame is signed with the user's own secret,
and a receiver checks the signature before it reads anything else of the frame.

**The secret** is 32 random bytes in a file only the user can read (`secret_path`: the file named by
`$WIITHROW_SECRET_FILE`, else `$XDG_CONFIG_HOME/wiithrow/zenoh-secret`, `~/.config/wiithrow/` without
it), written as 64 hex digits. The first wiithrow process that needs it makes it: the folder with
mode 0700, the file with mode 0600, written whole under a temporary name and linked into place (two
processes starting at once agree on one secret; none ever reads half a file). A file that another
user owns, or that its group or others may read, is refused in one line (`chmod 600`), and so is one
that is not 64 hex digits. Every process of the user reads the same file; a process of another user
cannot, and so cannot sign.

**The signature** of a sample is its Zenoh attachment: one version byte (`VERSION`) and
HMAC-SHA256(secret, key expression, a zero byte, payload): 33 bytes, about 2 us a frame on either
side. The key expression is signed too, so that a frame signed for one key is not taken on another.
The payload is unchanged JSON: a reader that does not check (`wiithrow listen`, a ROS bridge) reads
it as before.

**The check** (`FrameVerifier.check`), on Zenoh's callback thread before the sample is queued: a
sample without an attachment, with another version or with a signature that does not match is
`unauthenticated`; a signature seen among the last `REPLAY_WINDOW` is `replayed` (a copy of a
signed frame put again: the same bytes sign the same). Both are refused there, counted, and never
decoded. An older copy than the window carries a `seq` and `t` that do not follow the source's, and
is refused for that (`wiithrow.app.network.source_pin`).

Two hosts: the secret is this user's on this host; copy the file (mode 0600) to the other host, to
the same place or where `$WIITHROW_SECRET_FILE` says, as you would copy a key. A Zenoh session
opened with `--zenoh-config` keeps its own authentication (mutual TLS, access control) for who may
connect; the signature says, over any link, that the frame comes from a process holding the secret.
"""

from __future__ import annotations

import hmac
import os
import secrets
import stat
from collections import deque
from pathlib import Path

from wiithrow.app.errors import AppError

#: The environment variable that names the secret's file (tests, a service, a second user's setup).
SECRET_FILE_ENV = "WIITHROW_SECRET_FILE"
SECRET_BYTES = 32
#: The first byte of every signature: a change of the scheme raises it.
VERSION = b"\x01"
SIGNATURE_BYTES = 1 + 32
#: Signatures remembered to refuse a copy put again: 40 s of markers at 100 Hz (a copy older than
#: that does not follow the source's seq and is refused for it). Each costs about 100 bytes.
REPLAY_WINDOW = 4096
#: The longest secret file read (a few lines of hex; anything longer is not one).
MAX_SECRET_FILE_BYTES = 1024

UNAUTHENTICATED = "unauthenticated"
REPLAYED = "replayed"


def secret_path() -> Path:
    """Where this user's secret is: `$WIITHROW_SECRET_FILE`, else the per-user config folder."""
    named = os.environ.get(SECRET_FILE_ENV, "").strip()
    if named:
        return Path(named).expanduser()
    config = os.environ.get("XDG_CONFIG_HOME", "").strip()
    base = Path(config) if config else Path.home() / ".config"
    return base / "wiithrow" / "zenoh-secret"


def load_secret(path: Path | None = None) -> bytes:
    """This user's secret (made on first use: the module docstring); AppError, one line, when the
    file is another user's, readable by others or not a secret."""
    path = secret_path() if path is None else path
    try:
        return _read(path)
    except FileNotFoundError:
        pass
    _create(path)
    try:
        return _read(path)
    except FileNotFoundError:
        raise AppError(f"the secret file {path} vanished as it was made") from None


def _read(path: Path) -> bytes:
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NOFOLLOW)
    except FileNotFoundError:
        raise
    except OSError as exc:
        raise AppError(
            f"cannot read the secret file {path}: {exc.strerror} (${SECRET_FILE_ENV} names another)"
        ) from None
    try:
        info = os.fstat(fd)
        if not stat.S_ISREG(info.st_mode):
            raise AppError(f"the secret file {path} is not a regular file")
        if info.st_uid != os.getuid():
            raise AppError(f"the secret file {path} belongs to another user (uid {info.st_uid}): make your own")
        if info.st_mode & 0o077:
            raise AppError(
                f"the secret file {path} may be read by others (mode {stat.S_IMODE(info.st_mode):04o}): "
                f"`chmod 600 {path}`, or remove it to make a new one"
            )
        data = os.read(fd, MAX_SECRET_FILE_BYTES + 1)
    finally:
        os.close(fd)
    text = data.decode("ascii", errors="replace").strip()
    try:
        secret = bytes.fromhex(text)
    except ValueError:
        secret = b""
    if len(data) > MAX_SECRET_FILE_BYTES or len(secret) != SECRET_BYTES:
        raise AppError(f"the secret file {path} is not {2 * SECRET_BYTES} hex digits: remove it to make a new one")
    return secret


def _create(path: Path) -> None:
    """Write a new secret at `path` unless another process did first (then theirs stays)."""
    try:
        path.parent.mkdir(mode=0o700, parents=True, exist_ok=True)
    except OSError as exc:
        raise AppError(f"cannot make the folder of the secret file {path}: {exc.strerror}") from None
    temporary = path.with_name(f".{path.name}.{os.getpid()}.{secrets.token_hex(4)}")
    try:
        fd = os.open(temporary, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW, 0o600)
        try:
            os.write(fd, (secrets.token_bytes(SECRET_BYTES).hex() + "\n").encode("ascii"))
            os.fsync(fd)
        finally:
            os.close(fd)
        try:
            os.link(temporary, path)  # fails if another process made it first: theirs is kept
        except FileExistsError:
            pass
    except OSError as exc:
        raise AppError(f"cannot write the secret file {path}: {exc.strerror}") from None
    finally:
        try:
            os.unlink(temporary)
        except OSError:
            pass


def _signed_bytes(key: str, payload: bytes) -> bytes:
    return key.encode("utf-8") + b"\x00" + payload


class FrameSigner:
    """Signs what a publisher puts (`sign`: the attachment of a sample)."""

    def __init__(self, secret: bytes) -> None:
        self._secret = bytes(secret)

    @classmethod
    def for_this_user(cls) -> FrameSigner:
        return cls(load_secret())

    def sign(self, key: str, payload: bytes) -> bytes:
        """The attachment of `payload` put on `key`: `VERSION` and its HMAC-SHA256."""
        return VERSION + hmac.digest(self._secret, _signed_bytes(key, payload), "sha256")


class FrameVerifier:
    """Checks what a subscriber receives (`check`); not thread-safe: its caller serialises it."""

    def __init__(self, secret: bytes, replay_window: int = REPLAY_WINDOW) -> None:
        self._secret = bytes(secret)
        self._recent: deque[bytes] = deque()
        self._seen: set[bytes] = set()
        self.replay_window = replay_window

    @classmethod
    def for_this_user(cls) -> FrameVerifier:
        return cls(load_secret())

    def check(self, key: str, payload: bytes, attachment: bytes | None) -> str | None:
        """None when the sample is signed with the secret and new; else why not (`UNAUTHENTICATED`,
        `REPLAYED`)."""
        if attachment is None or len(attachment) != SIGNATURE_BYTES or attachment[:1] != VERSION:
            return UNAUTHENTICATED
        expected = hmac.digest(self._secret, _signed_bytes(key, payload), "sha256")
        if not hmac.compare_digest(expected, attachment[1:]):
            return UNAUTHENTICATED
        if attachment in self._seen:
            return REPLAYED
        self._seen.add(attachment)
        self._recent.append(attachment)
        if len(self._recent) > self.replay_window:
            self._seen.discard(self._recent.popleft())
        return None
