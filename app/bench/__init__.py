"""Benchmarks behind `wiithrow bench NAME --json`: speed and memory goals live here, not in tests.

Each benchmark module exposes `run(quick: bool) -> dict` returning JSON-ready figures.
"""

BENCHMARKS = {
    "triangulate": "app.bench.triangulate",
    "tracking": "app.bench.tracking",
    "throwing": "app.bench.throwing",
    "dashboard": "app.bench.dashboard",
}
