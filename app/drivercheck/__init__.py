"""Checking an arm driver (and a hand driver) before it throws: `wiithrow check-driver`.

Modules (one job each): `bounds` (the bounds a driver is judged by, with their reasons, and the
sizes of the check's motions), `motions` (the check's validated motions: slow, the Stop's, the
scaled throw and the throwing speed, planned from the arm's model), `probes` (the arm's
measurements), `speed_probe` (the speed it reaches), `hand_probe` (the hand's release),
`lag_cause` (which term a lagging controller is missing), `host` (the host's own lateness, never
the driver's), `plausibility` (whether the state is measured, not a copy of the command),
`rig_probe` (the rig watching the arm move), `procedure` (their order, gating and safe ends),
`report` (the results, as a table and as JSON), `store` (where reports are kept and
`driver_report_status`, what a throw on hardware asks before it starts). docs/robot.md,
"Checking a driver", says what each check does and why its bounds are what they are.
"""

from wiithrow.app.drivercheck.store import driver_report_status

__all__ = ["driver_report_status"]
