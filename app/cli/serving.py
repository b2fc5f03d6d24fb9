"""Serving a session with the dashboard from the command line (`wiithrow demo`, `wiithrow serve`).

Owns `run_dashboard`: start the dashboard, print its address (and the warning for an address
beyond this machine), optionally start a calibration, run until Ctrl-C or a duration, then stop
the arm, let the running operation end and close everything.
"""

from __future__ import annotations

import sys
import time

from wiithrow.app.session import Session


def run_dashboard(
    session: Session,
    *,
    host: str,
    port: int,
    default_poses: int = 30,
    calibrate_poses: int = 0,
    duration: float | None = None,
) -> int:
    """Serve `session` with the dashboard until Ctrl-C (or `duration` s): print the address (and
    the warning for a host other than loopback), start a calibration of `calibrate_poses` poses if
    > 0; at the end stop the arm, let the running operation end, close everything."""
    from wiithrow.web.exposure import exposure_warning, is_local_host
    from wiithrow.web.server import Dashboard

    dashboard = Dashboard(session, host=host, port=port, default_poses=default_poses)
    try:
        dashboard.start()
        print(f"wiithrow dashboard: {dashboard.url}  (Ctrl-C to stop)", flush=True)
        if not is_local_host(host):
            print(exposure_warning(host, dashboard.port), file=sys.stderr, flush=True)
        if calibrate_poses > 0:
            dashboard.start_calibration(calibrate_poses)
        end = None if duration is None else time.monotonic() + duration
        while end is None or time.monotonic() < end:
            time.sleep(0.2)
    except KeyboardInterrupt:
        pass
    finally:
        session.stop()
        dashboard.runner.join(timeout=5.0)
        dashboard.close()
        session.close()
    return 0
