"""The running system: the simulated or real world (arm, rig, markers, ball), calibration runs,
joint-1 alignment, throw sessions, the command line, benchmarks and figure reproduction.

May import `vision`, `robot` and `throwing`; `web` sits above it and only uses its public API.
"""
