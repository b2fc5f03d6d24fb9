"""Benchmarks behind `wiithrow bench NAME --json`: speed and memory goals live here, not in tests.

Each benchmark module exposes `run(quick: bool) -> dict` returning JSON-ready figures.
"""

BENCHMARKS = {
    "triangulate": "wiithrow.app.cli.bench.triangulate",
    "tracking": "wiithrow.app.cli.bench.tracking",
    "throwing": "wiithrow.app.cli.bench.throwing",
    "dashboard": "wiithrow.app.cli.bench.dashboard",
    "calibration": "wiithrow.app.cli.bench.calibration",
    "soak": "wiithrow.app.cli.bench.soak",
    "wand": "wiithrow.app.cli.bench.wand",
    "publish": "wiithrow.app.cli.bench.publish",
    "ros2": "wiithrow.app.cli.bench.ros2",
    "record": "wiithrow.app.cli.bench.record",
    "guest-flood": "wiithrow.app.cli.bench.guest_flood",
    "learning": "wiithrow.app.cli.bench.learning",
    "latency": "wiithrow.app.cli.bench.latency",
    "following": "wiithrow.app.cli.bench.following",
}
