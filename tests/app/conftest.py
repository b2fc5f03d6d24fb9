"""Fixtures the app tests share."""

from __future__ import annotations

import pytest

from wiithrow.app.cli.bench.publish import free_port
from wiithrow.app.network.zenoh_session import LOCAL_PORT_ENV, open_session


@pytest.fixture
def local_meeting(monkeypatch):
    """This host's local Zenoh meeting on a free port of the test's own (the processes it starts
    inherit it): every session links to every other, as wiithrow's processes on one machine do, so a
    rogue there reads the real publisher's frames. Yields the first session (it holds the meeting's
    port, the subscriber) and the connect configuration the others use ("local")."""
    monkeypatch.setenv(LOCAL_PORT_ENV, str(free_port()))
    subscriber = open_session(None)
    yield subscriber, "local"
    subscriber.close()
