"""Track four IR markers with two simulated Wiimotes, through the same code as real remotes.

Each simulated remote speaks the Wiimote's HID bytes to the real driver (`WiimoteDriver`), which
starts its IR camera and decodes its reports; `RigStream` synchronises the two unsynchronised
remotes, matches their dots and tracks the markers with persistent ids. Time is a `SimClock`, so
this runs as fast as the CPU allows (`pump` lets it pass, reading the rig at each step; the rig
keeps what it tracked: `tracked_since`); the markers cross each other at up to 2 m/s.

    python examples/02_track_simulated_remotes.py
"""

import numpy as np

from wiithrow.app.rig.moving_markers import crossing_paths
from wiithrow.app.rig.simulated import simulated_drivers
from wiithrow.app.rig.stream import RigStream
from wiithrow.app.rig.waiting import pump
from wiithrow.clock import SimClock
from wiithrow.vision.rig import stereo_rig

clock = SimClock()
cameras = stereo_rig()  # their true projection matrices stand in for a calibration here
drivers, remotes = simulated_drivers(cameras, lambda t: crossing_paths(t), clock, np.random.default_rng(0))
rig = RigStream(drivers, np.stack([c.P for c in cameras]))
rig.connect()  # the IR start sequence, over HID bytes

start = clock.now()
pump(clock, rig, 2.0, step_s=0.01)  # 2 s, reading the remotes every 10 ms
frames = rig.tracked_since(start)
rig.close()

last = frames[-1]
print(f"{len(frames)} tracked frames in 2 s of simulated time; the last at t = {last.t:.3f} s:")
truth = crossing_paths(last.t)
for marker_id, position, seen in zip(last.ids, last.position, last.visible):
    if seen:
        error = np.min(np.linalg.norm(truth - position, axis=1))
        print(
            f"  marker {marker_id}: {np.round(position, 3)} m (link1), {1e3 * error:.1f} mm from the nearest true marker"
        )
