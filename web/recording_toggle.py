"""The dashboard's Record toggle: one recording of the session at a time, operators only.

`RecordToggle` owns the session's recording while the dashboard serves: the one `--record` started
(if any) and those the Record button starts and stops. A click is checked on the server, as every
click is (`Clients.is_operator`: a guest's is refused, logged and told), then starts a
`SessionRecorder` into a new file in `folder` (`wiithrow-YYYYMMDD-HHMMSS.mcap`, checked first) or
closes the running one; every client's button then says which (`ClientControls.show_recording`).
A recording that stops by itself (a full disk) is told to every client.
"""

from __future__ import annotations

import threading
from datetime import datetime
from pathlib import Path
from typing import TYPE_CHECKING

import viser

from wiithrow.app.errors import AppError
from wiithrow.app.recording.session import SessionRecorder
from wiithrow.vision.errors import VisionError
from wiithrow.vision.outputs import check_output_file

if TYPE_CHECKING:
    from wiithrow.web.server import Dashboard


class RecordToggle:
    """Adds the Record toggle to `dashboard` (before it starts) and owns the recording."""

    def __init__(self, dashboard: Dashboard, folder: Path, recorder: SessionRecorder | None = None) -> None:
        self.dashboard = dashboard
        self.folder = Path(folder)
        self.recorder = recorder
        self._lock = threading.Lock()
        dashboard.add_recording(self.on_click, self.active)

    def active(self) -> bool:
        recorder = self.recorder
        return recorder is not None and recorder.active

    def on_click(self, event: viser.GuiEvent) -> None:
        if not self.dashboard.clients.is_operator(event.client, "Record"):
            return
        self.toggle(event.client)

    def toggle(self, client: viser.ClientHandle | None = None) -> Path | None:
        """Start a recording (its file), or stop the running one (None)."""
        with self._lock:
            if self.active() and self.recorder is not None:
                path = self.recorder.path
                self.recorder.close()
                self.recorder = None
                self._show()
                self.dashboard.notify(None, "Recording stopped", f"{path} is complete")
                return None
            path = self.folder / f"wiithrow-{datetime.now().strftime('%Y%m%d-%H%M%S')}.mcap"
            try:
                check_output_file(path, replace=False)
                recorder = SessionRecorder(self.dashboard.session, path, on_error=self._failed)
                recorder.begin()
            except (AppError, VisionError) as exc:
                self.dashboard.notify(client, "Cannot record", str(exc), "red")
                return None
            self.recorder = recorder
            self._show()
            self.dashboard.notify(None, "Recording", f"the session is recorded to {path}")
            return path

    def _failed(self, message: str) -> None:
        self._show()
        self.dashboard.notify(None, "Recording stopped", message, "red")

    def _show(self) -> None:
        active = self.active()
        for controls in self.dashboard.clients.controls():
            try:
                controls.show_recording(active)
            except Exception:  # the client went away
                pass

    def close(self) -> None:
        """Close the running recording, if any."""
        with self._lock:
            if self.recorder is not None:
                self.recorder.close()
                self.recorder = None
