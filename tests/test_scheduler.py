"""The suite's scheduler (tests/conftest.py, `costliest_modules_first`) on a simulated run: workers
as pytest-xdist's scheduler sees them (each runs a test only once it knows the next one or is told
to stop, as xdist's worker does), tests with seeded durations, and the run's length measured.

It hands the modules out browser scope first, then costliest first; the browser modules run on one
worker; and its run ends within the longest-processing-time bound, where loadfile's collection
order, with the long modules collected last, keeps one worker busy alone at the end (seeds 0, 1,
2: 326, 277, 307 s against loadfile's 370, 310, 347 s; the best possible is at least 325, 276,
307 s).
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from xdist.scheduler import LoadFileScheduling

from tests.conftest import BROWSER_MODULES, BROWSER_SCOPE, costliest_modules_first

WORKERS = 3


class Worker:
    """What the scheduler needs of a worker: its queue of test indices, and a shutdown."""

    def __init__(self, name: str, sent: list[list[int]]) -> None:
        self.name, self.sent = name, sent
        self.gateway = SimpleNamespace(id=name)  # named in the scheduler's comparison of collections
        self.queue: list[int] = []
        self.shutting_down = False

    def send_runtest_some(self, indices: list[int]) -> None:
        self.queue.extend(indices)
        self.sent.append(list(indices))

    def shutdown(self) -> None:
        self.shutting_down = True


class QuietLog:
    """The scheduler's log (`log.loadfilesched(...)`), saying nothing."""

    def __getattr__(self, name: str) -> QuietLog:
        return self

    def __call__(self, *args: object) -> None:
        pass


class Config:
    """The two options the scheduler reads: the workers (`--tx`) and loadscope's reordering."""

    class option:
        loadscopereorder = False

    def getvalue(self, name: str) -> list[str]:
        assert name == "tx"
        return [f"{WORKERS}*popen"]


def simulate(scheduler: type, modules: dict[str, list[float]]) -> tuple[float, list[list[int]], dict[str, str]]:
    """Runs `modules` (module -> its tests' seconds, in collection order) on `WORKERS` simulated
    workers. Returns the run's length (s), the work units in the order they were sent, and which
    worker ran each test."""
    collection = [f"{module}::test_{i}" for module, tests in modules.items() for i in range(len(tests))]
    seconds = [s for tests in modules.values() for s in tests]
    sent: list[list[int]] = []
    workers = [Worker(f"gw{i}", sent) for i in range(WORKERS)]
    sched = scheduler(Config(), QuietLog())
    for worker in workers:
        sched.add_node(worker)
    for worker in workers:
        sched.add_node_collection(worker, collection)
    sched.schedule()
    now, ends, ran_on = 0.0, {}, {}
    while True:
        for worker in workers:  # an idle worker starts its next test if it may (xdist: it knows the next, or stops)
            if worker not in ends and worker.queue and (len(worker.queue) >= 2 or worker.shutting_down):
                ends[worker] = now + seconds[worker.queue[0]]
        if not ends:
            break
        worker = min(ends, key=ends.__getitem__)  # the next test to end
        now = ends.pop(worker)
        index = worker.queue.pop(0)
        ran_on[collection[index]] = worker.name
        sched.mark_test_complete(worker, index)
    assert len(ran_on) == len(collection), "every test ran once"
    return now, sent, ran_on


def suite(seed: int) -> dict[str, list[float]]:
    """40 short modules collected first, then 4 long ones and the browser modules (seeded seconds)."""
    rng = np.random.default_rng(seed)
    modules = {f"tests/short/test_{i}.py": list(rng.uniform(0.1, 2.0, rng.integers(3, 12))) for i in range(40)}
    modules.update({f"tests/long/test_{i}.py": list(rng.uniform(10.0, 40.0, 4)) for i in range(4)})
    modules.update({module: list(rng.uniform(5.0, 30.0, 3)) for module in BROWSER_MODULES[:4]})  # four of them
    return modules


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_costliest_modules_first_and_the_browser_modules_on_one_worker(seed):
    modules = suite(seed)
    costs = {module: sum(tests) for module, tests in modules.items()}
    costs[BROWSER_SCOPE] = sum(costs.pop(module) for module in BROWSER_MODULES if module in costs)
    length, sent, ran_on = simulate(costliest_modules_first(costs), modules)

    scope = {name: (BROWSER_SCOPE if name in BROWSER_MODULES else name) for name in modules}
    collection = [f"{module}::test_{i}" for module, tests in modules.items() for i in range(len(tests))]
    order = [scope[collection[unit[0]].split("::")[0]] for unit in sent]
    assert order[0] == BROWSER_SCOPE
    assert order[1:] == sorted(order[1:], key=lambda s: -costs[s]), "costliest first"
    assert len({ran_on[test] for test in ran_on if test.split("::")[0] in BROWSER_MODULES}) == 1

    # Graham's bound for longest processing time first: within (4/3 - 1/(3m)) of the best run,
    # itself at least the total over the workers and at least the longest scope
    best = max(sum(costs.values()) / WORKERS, max(costs.values()))
    assert length <= (4 / 3 - 1 / (3 * WORKERS)) * best, (length, best)

    # loadfile's own order (the collection's) finds the long modules last: a longer run
    plain, _, _ = simulate(LoadFileScheduling, modules)
    assert plain > 1.1 * length, (plain, length)
