"""The bounds a driver is judged by in `wiithrow check-driver`, each with its reason, and the sizes
of the check's own motions (how small, how slow, how gentle).

Every bound is what the rest of the system assumes of an arm or a hand; a driver that misses one
would make the throw wrong in a way that the planner cannot see and the learning of the throw
library cannot absorb (a constant delay it can absorb; a varying one it cannot). Distances at the
ball follow from the lever of about 1 m between the throwing joints and the ball: 1 mrad of joint
error is about 1 mm at the ball.
"""

from __future__ import annotations

from wiithrow.throwing import OperatorSettings
from wiithrow.throwing.representation import VELOCITY_MARGIN

# -- the check's own motions -----------------------------------------------------------------------

#: How often the check reads the arm and the hand (s): twice per 1 kHz servo period, so that a new
#: sample every millisecond is seen as one.
POLL_S = 0.0005
#: How long the state's rate and latency are measured, the arm at rest (s), and how often it is
#: read then (s): ten times per servo period, so that the reads do not limit the rate measured.
STATE_PROBE_S = 0.5
STATE_POLL_S = 0.0001
#: The small slow motion: every joint out by this much (rad, away from its nearer limit) and back,
#: at these fractions of its velocity, acceleration and jerk limits.
SLOW_STEP_RAD = 0.1
SLOW_LIMIT_FRACTION = 0.2
#: The Stop probe: the joints move by this much (rad) at these fractions of their limits, and Stop
#: comes when the move is this far through (its cruise).
STOP_MOVE_RAD = 0.4
STOP_LIMIT_FRACTION = 0.3
STOP_AT_FRACTION = 0.4
#: How far beyond a joint limit the refused command is (rad).
BEYOND_LIMIT_RAD = 0.05
#: The scaled throw: the simulated operator's throw to the middle of the arm's training area (its
#: spec's), planned from the arm's model and validated, slowed down by this factor (t -> s t:
#: velocities / s, accelerations / s^2, jerks / s^3: at 2, a throw at 95 % of the velocity limits
#: runs at 48 %, its accelerations at 25 %).
THROW_TIME_SCALE = 2.0
#: The throwing-speed motion: the arm's throw shape released with every throwing joint at this
#: fraction of its velocity limit (or less where its acceleration or jerk limit caps the throw's
#: acceleration phase): the fastest release a trained throw asks of a joint, the simulated
#: operator's cap (`OperatorSettings.speed_cap`, 0.9) of the throw's velocity margin (95 %).
THROW_SPEED_FRACTION = OperatorSettings().speed_cap * VELOCITY_MARGIN
#: The speed of a joint, measured and planned alike: the difference of its positions over this
#: span (s) of the timestamps. Long enough that a position's noise does not make a peak (the
#: kinematic world's 1 mrad tracking error, correlated over 20 ms, adds about 0.06 rad/s to one
#: difference), short enough to keep the peak: the release has no acceleration, and the span
#: lowers the peak by jerk x span^2 / 24, in the command's differences as in the arm's.
SPEED_SPAN_S = 0.02
#: The window around the release (s, on the scaled throw's axis, either side) in which the lag at
#: the release is measured, and the shifts searched (s, either way).
RELEASE_WINDOW_S = 0.15
LAG_SEARCH_S = 0.1
#: After a motion's command ends, the arm has this long (s) to settle before the next probe.
SETTLE_S = 0.3
#: Rest: every joint slower than this (rad/s).
REST_SPEED_RAD_S = 0.01
#: The hand: this many close/release cycles, in the way a throw releases (`open_at` for a hand that
#: schedules its open, else `open()`).
HAND_CYCLES = 12
#: The jaws have started to part when their opening is this much above where they closed: 2 % of
#: the stroke, the earliest sign of a parting that a grip's settling and a reading's noise leave
#: (the MuJoCo hand reads its opening from the ball's surface: 0 while it holds). The ball is free
#: later, where the hand can tell (`holding`), and that is judged too.
HAND_PART_OPENING = 0.02
#: The hand is open at this opening: its open time, judged against the settings' `hand_open_s`.
HAND_OPEN_FRACTION = 0.9
#: How long (s) a hand that states no close or open time has to close or to open; one that states
#: them (`hand_close_s`, `hand_open_s`) has twice its own, at least this.
HAND_TIMEOUT_S = 1.0
#: How far ahead (s) a scheduled release is given (`open_at(now + lead)`): the host's own lateness
#: in giving it must not eat into it.
HAND_SCHEDULE_LEAD_S = 0.1
#: A release is timed only when the host read the hand at most this long (s) after its read before,
#: or the state it got is stamped within this of that read (the jaws parted, the ball left,
#: between the two), and a host-timed `open()` returned within this of the time it was taken at. A
#: host that read later (a thread woken late on a loaded machine: 10-40 ms beside the suite's four
#: workers) cannot say when; that cycle is done again, at most `HAND_HOST_LATE_CYCLES` times; beyond,
#: the check is not run and says how late the host was (not a fault of the hand).
HAND_READ_GAP_MAX_S = 0.002
HAND_HOST_LATE_CYCLES = 3 * HAND_CYCLES

# -- the bounds ------------------------------------------------------------------------------------

#: The state's sample rate, at least (Hz: 1 / the median step of its timestamps). The host commands trajectories at 1 kHz and reads the arm
#: every 10 ms control period and at the release; half the servo rate leaves every read at most
#: 2 ms old on average.
STATE_RATE_MIN_HZ = 500.0
#: The age of a state when it is read (clock now - its timestamp, s): median and 95th percentile
#: at most. The release is commanded from the clock; a state 3 ms old at 2 rad/s is 6 mrad, about
#: 6 mm at the ball, already a third of the 15 mm landing goal.
STATE_AGE_MEDIAN_MAX_S = 0.003
STATE_AGE_P95_MAX_S = 0.010
#: A state from the future by more than this (s) is on another clock than the one the driver was
#: given (the Arm contract: states are on the host's clock).
STATE_AGE_MIN_S = -0.001
#: Following the slow motion (rad, worst joint): RMS and largest error against the command at the
#: sample's time. At a fifth of the limits an arm that follows its trajectory stays within a few
#: milliradians of it; the wrist joints, whose limits are the fastest, lag most where the motion
#: turns back (the MuJoCo PA-10: 2.2 mrad RMS, 8.7 mrad at W2's turn). A driver 50 ms late is
#: 10-60 mrad off at these speeds.
SLOW_RMS_MAX_RAD = 0.005
SLOW_MAX_MAX_RAD = 0.015
#: Following the scaled throw (rad, worst joint): 5 mrad RMS is about 5 mm at the ball, a third of
#: the landing goal; the largest error 20 mrad (the wrist's brief peaks at the start of the swing).
THROW_RMS_MAX_RAD = 0.005
THROW_MAX_MAX_RAD = 0.020
#: The lag at the release (s, either way): the time shift that best aligns the measured joints to
#: the commanded ones around the release. The ball leaves at about 4.5 m/s at full speed: 5 ms is
#: about 2 cm along its path; the library learns a constant lag but not one that changes with the
#: throw's speed, and a driver that lags more than this plans on a model the planner does not have.
LAG_MAX_S = 0.005
#: Stop: at rest within the time the limits need to brake (Ruckig's brake from the commanded state
#: at Stop) plus this (s; the servo's settling), and no joint more than this (rad) beyond where the
#: ideal brake ends, and every joint within its limits throughout.
STOP_SETTLE_MAX_S = 0.5
STOP_OVERSHOOT_MAX_RAD = 0.02
#: A refused command moves no joint by more than this (rad).
REFUSED_MOTION_MAX_RAD = 0.001
#: The hand's release (s, from the scheduled release: the time given to `open_at`, or the call of
#: `open()`) until its jaws start to part, and until the ball is free (`holding` turns False, where
#: the hand can tell): the median of each at most this. Released this late, the ball leaves in the
#: follow-through's brake, where each millisecond more moves the landing 2-8 mm (the shipped arms'
#: throws over their areas, 20-30 ms after the release; 0-2 mm at 5 ms): a constant latency is
#: learned, but within it the jitter bound below still holds its 4.5 mm per millisecond.
HAND_RELEASE_MAX_S = 0.025
#: The latest release at most this (s): a hand that now and then lets go 50 ms late misses by
#: 10-30 cm then.
HAND_RELEASE_WORST_MAX_S = 0.050
#: The release's jitter (standard deviation over the cycles but the latest, which is bounded on its
#: own, so that one late release does not make it; s) at most this: a random release-time
#: error the learning cannot absorb, 4.5 mm of ball travel per millisecond at the release: beyond
#: 6 ms (twice the MuJoCo hand's 3 ms) 95 % of the landings spread over more than +-50 mm, the cup,
#: with nothing else wrong.
HAND_JITTER_MAX_S = 0.006

# -- a measured state, not a copy of the command (`plausibility`) --------------------------------

#: While the command moves, the fraction of new states whose joints equal one of the trajectory's
#: commanded samples bit for bit, at most: a servo's measured position equals a commanded double
#: only where the driver copies it (the MuJoCo and the kinematic world's drivers: none of some
#: 1400 states; an echo of the command: all of them). Beyond it the check fails: the following
#: checks judged the command against itself.
ECHO_FRACTION_MAX = 0.1
#: While the command moves, the fraction of consecutive new states (each newer than the last)
#: whose joints are bit for bit the same, at most: a state stamped when read, not when measured
#: (its age says less than it is). Ours: none. A warning, not a failure: some buses are read
#: faster than the arm refreshes them, and the state probe's age then hides up to one refresh.
REPEATED_FRACTION_MAX = 0.1
#: The state at rest carries no noise when every joint reads the very same value over the state
#: probe (`STATE_PROBE_S`, at least this many new samples): a servo's encoder jitters by a count
#: or its physics by far less (the MuJoCo PA-10: 8e-15 to 1e-10 rad standard deviation); an echo
#: of the held command does not. A warning: a braked joint on a coarse encoder can sit on one count.
REST_NOISE_MIN_SAMPLES = 100

# -- the arm seen moving by the rig (`rig_probe`) -----------------------------------------------

#: A marker within this distance (m) of where the state puts the hand's LED is taken for the LED
#: (more than twice the largest error allowed below); farther, the rig did not see the LED there.
RIG_GATE_M = 0.10
#: The rig's LED against the state's, by forward kinematics in link1 (m): the calibration's 3D
#: error (a robot calibration's few mm), the LED's tracking noise (about 1 mm), the arm's own
#: kinematic errors that the nominal model does not know, and a frame's time against the state's
#: (17 ms in the MuJoCo world: about 1 mm at the LED's speed here). Measured, the PA-10, Panda and
#: UR5e in both simulated worlds with the true and the robot calibrations: at most 5.7 mm RMS and
#: 7.0 mm largest (the MuJoCo PA-10, its tolerances). A joint 30 mrad off its zero, 0.7 m from the
#: LED, is 21 mm off.
RIG_ERROR_RMS_MAX_M = 0.015
RIG_ERROR_MAX_M = 0.040
#: Of the frames in which the state puts the LED in the rig's common view, the rig must see it in
#: at least this fraction (the tracker confirms a marker after a few frames; near an edge of the
#: view one camera may miss it).
RIG_SEEN_FRACTION_MIN = 0.8
#: The check decides only on at least this many such frames (0.5 s of the remotes' 100 Hz).
RIG_MIN_FRAMES = 50
#: The LED's travel the rig sees (the extent of its positions) against the travel the state says,
#: at least this fraction: an arm that stands still while its state moves is seen standing.
RIG_TRAVEL_FRACTION_MIN = 0.5
#: A frame is judged only when a state was read within this (s) before and after it (joints
#: interpolated between the two); a host that read the arm later cannot say where it was then.
RIG_STATE_GAP_MAX_S = 0.02
#: The view pose: the LED this far (px) inside every camera's image, at this depth (m) from the
#: first camera, the LED facing the rig: where the hands of the shipped arms reach in front of the
#: default rig, whose centre is 5 cm behind link1's axis (at 0.9 m at most the UR5e's found none).
RIG_VIEW_MARGIN_PX = 80.0
RIG_VIEW_DEPTH_M = (0.5, 1.05)
