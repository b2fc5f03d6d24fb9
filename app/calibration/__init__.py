"""Calibrating the rig: from known 3D points (`points`, `point_files`), and the paper's
robot-driven procedure (`robot`) on poses chosen for a small error (`poses`)."""
