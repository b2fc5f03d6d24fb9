"""Calibrating a rig of 2-4 Wiimotes with a wand: two LEDs a known distance apart, waved through
the volume (the method of easyWand and Argus, for cameras with unknown intrinsics).

`calibrate_wand(observations, wand_length_m)` (`calibrate`) runs the steps, one module each:
the observations and their CSV (`observations`, `wand_csv`); which dot is which end
(`ends`); each camera pair's relative pose (`relative_pose`: normalised eight-point, essential
matrix, cheirality), chained from camera 0 (`chain`) and scaled by the wand (`scale`); the bundle
adjustment of intrinsics, poses and every frame's wand (`bundle`); the frame the result is given
in (`frames`: the first camera, an L-frame, the robot); and the quality a user reads (`quality`).
`waver` simulates a person waving a wand in front of simulated remotes.
"""
