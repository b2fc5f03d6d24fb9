"""The live rig: C Wiimote drivers -> frame synchroniser -> marker tracker (`stream`), the
drivers over simulated remotes (`simulated`) or the real ones hidapi finds (`hardware`), moving
test markers (`moving_markers`), and waiting on the clock while the rig keeps reading (`waiting`)."""
