"""Fixtures shared by the whole suite.

* `pa10`: the PA-10's kinematic model (Pinocchio, from robot/urdf/pa10.urdf), built once per run;
  tests only read it.
* `sim_world`: the default simulated world, built once per run and never run: tests read its
  cameras, arm model, settings and true calibration. A test that lets time pass, moves the arm or
  lights a source builds its own world (`SimWorld(seed=...)` or `simulated_session(...)`); the
  fixture fails the run if its clock was moved.
* `cache_dir` (every test): the simulated rig's kept calibrations go to a temporary folder, one
  for the whole run (shared by the xdist workers, so each calibration is made once per run).
* `zenoh_local_port` (every test): Zenoh sessions opened without a config file (this host's
  loopback, `wiithrow.app.network.zenoh_session`) meet on a free port of the suite's own
  ($WIITHROW_ZENOH_PORT), never on a wiithrow the user runs on this machine.
* `zenoh_secret` (every test): the secret that signs published frames
  (`wiithrow.app.network.frame_auth`) is the worker's own ($WIITHROW_SECRET_FILE, made on first
  use), never the user's; child processes inherit it.
* The browser tests (marker `browser`): Debian's Chromium driven by Playwright, and a running
  dashboard on the simulated system in real time, opened by its operator's link (with the token).

Under pytest-xdist (`make test` runs `-n 4 --dist loadfile`), every test module runs on one
worker, so its module fixtures are built once, and the browser modules (`BROWSER_MODULES`) run on
one worker together: one Chromium and one real-time dashboard at a time, never two competing for
the two cores; the modules are handed out longest first by their recorded seconds
(`MODULE_SECONDS`, `pytest_xdist_make_scheduler`). Every fixture here is per worker: a worker's
session fixtures and its Zenoh port are its own; the cache folder is the run's.

The property tests (hypothesis) are derandomized: the same examples on every run (the profile below).

The tests of `SLOW_BY_MEASUREMENT` are marked `slow` (`pytest_itemcollected`): the costliest of the
timed run, so that `make test-fast` (no slow, no browser tests) takes minutes less; `make test` runs them.

Without Chromium (or the playwright package) the browser tests skip with the reason; with
WIITHROW_REQUIRE_BROWSER=1 (CI, `.ci/run`) they fail instead. The browser is started once per module;
the dashboard and two pages on it are started once per test module (so that their threads do not run behind the rest
of the suite), and the rig calibrated once (8 poses through the same path as the Calibrate
button, about 15 s of real time, while the pages start): every browser test starts from a
calibrated system with two browsers connected. Every page of the browser tests shows the 3D scene
as a thumbnail from its start (`small_scene_context`, `SMALL_SCENE`: the canvas and the box viser
sizes it from), so that software WebGL renders 120 x 90 pixels a frame, not the whole window, at
most 5 frames a second (`FEWER_FRAMES`), and the test dashboards draw it without shadows or
reflections (`PLAIN_SCENE`): Chromium's CPU is most of what the browser tests cost.
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest
from hypothesis import settings as hypothesis_settings

#: The property tests draw the same examples on every run (derandomized: seeded from each test's
#: name) and keep no example database in the working folder (tests run in parallel; a run repeats).
hypothesis_settings.register_profile("wiithrow", derandomize=True, database=None)
hypothesis_settings.load_profile("wiithrow")

REQUIRE_BROWSER = "WIITHROW_REQUIRE_BROWSER"


#: Tests (and modules: all their tests) marked `slow` here, not in their files: each cost 9 s or more
#: (a module fixture counted in its first test) in the suite's timed run on the shared 2-core machine at a
#: load of 12-16 (issue 23; about 3-5 x a quiet machine's times), together four fifths of the time of
#: `make test-fast`, which leaves them out (`make test` runs them). Kept here so that a file's own marks stay
#: its author's; a test named here that no longer exists is harmless.
SLOW_BY_MEASUREMENT = frozenset(
    {
        "tests/app/test_reproduce.py",
        # 45 s and 38 s alone on the shared machine (2026-12-06): 1,000 learning updates, 12 killed Finishes
        "tests/app/test_library_store.py::test_a_thousand_learning_updates_keep_the_folder_bounded",
        "tests/app/test_library_choice.py::test_a_crash_at_every_write_of_finish_leaves_the_previous_version_in_use",
        "tests/app/test_calibration_robot.py",
        "tests/app/test_calibration_wand.py",
        "tests/app/test_arm_training.py::test_an_arm_trains_and_throws_in_the_kinematic_world",
        "tests/app/test_replay_limits.py::test_a_decompression_bomb_is_refused_in_one_line_within_bounds",
        "tests/app/test_calibration_kinematic.py::test_the_mujoco_rig_measures_the_throwing_area_within_1_5x_the_true_cameras",
        "tests/app/test_alignment.py::test_converges_below_5_mm_within_3_s",
        "tests/app/test_alignment.py::test_follows_a_moving_target_until_stopped",
        "tests/app/test_alignment.py::test_finds_a_target_outside_the_field_of_view",
        "tests/app/test_alignment.py::test_commander_rebuilds_a_command_the_arm_refuses_after_a_hold_up",
        "tests/app/test_alignment.py::test_commander_brakes_before_the_joint_limit",
        "tests/app/test_check_driver.py::test_a_driver_50_ms_late_fails_following_with_its_lag",
        "tests/app/test_check_driver.py::test_the_mujoco_drivers_pass_every_check",
        "tests/app/test_check_driver.py::test_a_driver_that_ignores_stop_fails_stop",
        "tests/cli/test_zenoh_local.py::test_default_track_publish_listens_on_loopback_only_and_a_default_listen_receives_it",
        "tests/cli/test_throw.py::test_dry_run_json_is_a_complete_checkable_plan",
        "tests/cli/test_calibrate_wand.py::test_three_simulated_remotes_calibrate_and_then_track",
        "tests/cli/test_calibrate_wand.py::test_a_wrong_wand_length_is_caught_by_the_simulated_robot",
        "tests/cli/test_calibrate_wand.py::test_what_cannot_work_is_one_line_and_exit_2",
        "tests/cli/test_calibrate_wand.py::test_a_wand_csv_calibrates_and_prints_its_quality",
        "tests/cli/test_bad_files.py::test_track_to_dev_full_is_one_line_and_exit_2",
        "tests/vision/wand/test_calibrate_wand.py::test_new_points_are_as_accurate_as_with_the_true_cameras",
        "tests/vision/wand/test_calibrate_wand.py::test_missing_and_single_dots_still_calibrate",
        "tests/web/test_limits.py::test_a_flood_of_nested_and_refused_messages_is_logged_in_lines_read_at_its_rate_and_stop_still_works",
        "tests/web/test_access.py::test_a_foreign_websocket_gets_403_and_nothing_reaches_viser",
        "tests/test_layout.py::test_a_wheel_installs_only_the_one_name_with_the_linked_folders_copied_in",
        # 9 s or more in a timed `make test-fast` run (03:04-03:12 UTC 2026-12-02, load 3-8: 8 min 34 s)
        "tests/cli/test_bench_throwing.py::test_bench_throwing_quick_in_the_kinematic_world",
        "tests/test_examples.py::test_example_runs[06_another_arm_in_mujoco.py]",
        "tests/test_examples.py::test_example_runs[05_throw_in_the_simulated_world.py]",
        "tests/web/test_dashboard_wand.py::test_a_wand_calibration_drives_the_dashboard",
        "tests/cli/test_progress_bars.py::test_train_shows_its_throws_on_a_terminal",
        "tests/app/test_zenoh_security.py::test_the_two_host_example_carries_the_markers_and_shuts_out_unauthenticated_peers",
        "tests/cli/test_bad_input_property.py::test_calibrate_from_files_and_the_demo",
        "tests/cli/test_calibrate_robot.py::test_sim_robot_calibration_prints_json_and_writes_the_file",
        "tests/app/test_training.py::test_a_small_library_trained_through_the_rig",
        "tests/cli/test_json_output.py::test_train",
        "tests/app/test_sim_calibration.py::test_the_last_calibration_is_reused_while_valid_and_each_run_says_which",
        "tests/app/test_mujoco_arms.py::test_serve_runs_the_arm_over_the_mujoco_drivers",
        # 7.5 s or more in a timed `-n 3` test-fast run (06:25-06:29 UTC 2026-12-02, load 3-7: 4 min 5 s);
        # each module keeps tests in test-fast (test_progress_bars its [False-False-False] case)
        "tests/cli/test_bad_input_property.py::test_reproduce_serve_demo_bench",
        "tests/cli/test_progress_bars.py::test_calibrate_robot_sim_shows_its_poses_on_a_terminal_only[True-True-False]",
        "tests/cli/test_progress_bars.py::test_calibrate_robot_sim_shows_its_poses_on_a_terminal_only[True-False-True]",
        "tests/cli/test_calibrate_robot.py::test_six_poses_say_leave_one_out_needs_seven_and_store_null",
        "tests/cli/test_calibrate_robot.py::test_sim_robot_calibration_table",
        "tests/cli/test_bench_tracking.py::test_bench_tracking_attaches_the_ros2_and_foxglove_publishers_and_tracks_the_same",
        "tests/app/test_training_run.py::test_the_area_is_bounded_by_the_arms_reach_at_the_velocity_margin",
        "tests/app/test_training_run.py::test_training_in_the_session_stops_resumes_and_ends_with_the_library_in_use",
        "tests/vision/test_crossval.py::test_refined_methods_within_the_stated_bound_of_refitting[robust-True]",
        "tests/cli/test_zenoh_local.py::test_default_track_publish_in_a_network_namespace_of_its_own_joins_no_multicast_group",
        "tests/app/test_calibration_kinematic.py::test_an_exact_arm_keeps_its_nominal_kinematics",
        "tests/cli/test_ros2_flags.py::test_bench_ros2_counts_every_frame_a_subscriber_process_received",
        "tests/cli/test_train.py::test_the_default_library_is_not_replaced_without_force",
    }
)


#: The browser test modules (marker `browser`), run on one xdist worker together; a browser test in
#: a module not named here stops the collection (`pytest_itemcollected`), so the list stays whole.
BROWSER_MODULES = (
    "tests/web/test_browser.py",
    "tests/web/test_browser_demo.py",
    "tests/web/test_browser_mujoco.py",
    "tests/web/test_training_browser.py",
    "tests/web/test_library_browser.py",
)


def pytest_itemcollected(item: pytest.Item) -> None:
    """Mark the tests of `SLOW_BY_MEASUREMENT` slow as they are collected (before `-m` selects), and
    refuse a browser test outside `BROWSER_MODULES` (it would run beside another browser under xdist)."""
    test = item.nodeid.split("[", 1)[0]
    module = test.split("::", 1)[0]
    if SLOW_BY_MEASUREMENT & {item.nodeid, test, module}:  # one case, all cases of a test, or a module
        item.add_marker(pytest.mark.slow)
    if item.get_closest_marker("browser") is not None and module not in BROWSER_MODULES:
        raise pytest.UsageError(f"{module} has browser tests: name it in tests/conftest.py's BROWSER_MODULES")


#: Seconds each test module took on one worker in a timed run (its tests' setup, call and teardown):
#: the scheduler starts the costliest first. Rewritten, for the modules a run ran, by
#: `pytest -n 4 --dist loadfile --record-module-seconds`; a module not in it counts as 0 s (it runs
#: among the short ones, in collection order).
MODULE_SECONDS = Path(__file__).with_name("module_seconds.json")

#: The scope of the browser modules under `--dist loadfile` (one worker runs them all, see below).
BROWSER_SCOPE = "browser"


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addoption(
        "--record-module-seconds",
        action="store_true",
        help=f"write each module's measured seconds into {MODULE_SECONDS.name} (the scheduler's order)",
    )


def recorded_module_seconds() -> dict[str, float]:
    """Module (or `BROWSER_SCOPE`) -> its recorded seconds (`MODULE_SECONDS`); {} when unreadable."""
    import json

    try:
        seconds = json.loads(MODULE_SECONDS.read_text())["seconds"]
    except (OSError, ValueError, KeyError, TypeError):
        return {}
    costs = {str(module): float(s) for module, s in seconds.items()}
    costs[BROWSER_SCOPE] = sum(costs.pop(module, 0.0) for module in BROWSER_MODULES)
    return costs


class ModuleSecondsRecorder:
    """Sums the reports' durations per module on the controller; writes them at the end of the run."""

    def __init__(self) -> None:
        self.seconds: dict[str, float] = {}

    def pytest_runtest_logreport(self, report: pytest.TestReport) -> None:
        module = report.nodeid.split("::", 1)[0]
        self.seconds[module] = self.seconds.get(module, 0.0) + report.duration

    def pytest_sessionfinish(self, session: pytest.Session) -> None:
        import json

        try:
            recorded = json.loads(MODULE_SECONDS.read_text())["seconds"]
        except (OSError, ValueError, KeyError):
            recorded = {}
        recorded.update({module: round(s, 1) for module, s in self.seconds.items()})
        document = {
            "about": "seconds per test module on one worker (tests/conftest.py: MODULE_SECONDS)",
            "seconds": dict(sorted(recorded.items(), key=lambda item: -item[1])),
        }
        MODULE_SECONDS.write_text(json.dumps(document, indent=1) + "\n")


def pytest_configure(config: pytest.Config) -> None:
    if config.getoption("record_module_seconds") and not hasattr(config, "workerinput"):  # the controller only
        config.pluginmanager.register(ModuleSecondsRecorder(), "wiithrow-module-seconds")


@pytest.hookimpl(optionalhook=True)  # pytest-xdist's hook: absent without it
def pytest_xdist_make_scheduler(config: pytest.Config, log: object) -> object:
    """Under `--dist loadfile`: `costliest_modules_first` with the recorded seconds."""
    if config.getoption("dist") != "loadfile":
        return None
    return costliest_modules_first(recorded_module_seconds())(config, log)


def costliest_modules_first(costs: dict[str, float]) -> type:
    """pytest-xdist's loadfile scheduler (see the module docstring): a module per worker, as loadfile does, and
    the browser modules as one scope, costliest first, the browser scope on a worker of its own.

    Longest processing time first (`MODULE_SECONDS`): each free worker takes the costliest module
    left, so the long modules (many wait on real time) start at once and the short ones fill the
    end, instead of one long module found late keeping one worker busy alone at the end. A worker
    is given its next module when one test of its current one is left (loadfile's default is two:
    a module committed early to a worker busy with a long test is a module another worker could
    have run). The browser scope starts first (its real time is the longest of one worker's), and
    its worker runs the browser modules one after the other: one Chromium and one real-time
    dashboard at a time.
    (`--dist loadgroup` would say the grouping with marks, but it
    silently stops grouping under pytest 9.2: pytest-xdist issue #1386.)"""
    from xdist.scheduler import LoadFileScheduling
    from xdist.workermanage import WorkerController

    class CostliestModulesFirst(LoadFileScheduling):
        def _split_scope(self, nodeid: str) -> str:
            module = nodeid.split("::", 1)[0]
            return BROWSER_SCOPE if module in BROWSER_MODULES else module

        def _assign_work_unit(self, node: WorkerController) -> None:
            costliest = max(  # the browser scope first; then the costliest; the first of equals
                self.workqueue, key=lambda scope: (scope == BROWSER_SCOPE, costs.get(scope, 0.0))
            )
            self.workqueue.move_to_end(costliest, last=False)
            super()._assign_work_unit(node)

        def _reschedule(self, node: WorkerController) -> None:
            if not node.shutting_down and self.workqueue and self._pending_of(self.assigned_work[node]) == 2:
                return  # loadfile would commit its next module to it now; one test left is soon enough
            super()._reschedule(node)

    return CostliestModulesFirst


@pytest.fixture(scope="session")
def pa10():
    """The PA-10 model, shared by every test that only reads it."""
    from wiithrow.robot import load_arm

    return load_arm("pa10")


@pytest.fixture(scope="session")
def sim_world():
    """The default simulated world, for tests that only read it (see the module docstring)."""
    from wiithrow.app.worlds import SimWorld

    world = SimWorld(seed=0)
    yield world
    assert world.clock.now() == 0.0, "a test ran the shared sim_world: build a world of your own to run one"


@pytest.fixture(scope="session", autouse=True)
def cache_dir(tmp_path_factory):
    """The suite keeps the simulated rig's calibrations in a folder of its own, never the user's
    (~/.cache/wiithrow): `wiithrow.app.calibration.simulated`."""
    root = tmp_path_factory.getbasetemp()
    if os.environ.get("PYTEST_XDIST_WORKER"):  # one folder for the run's workers: a calibration made once per run
        root = root.parent  # (kept files are written atomically: two workers making the same one agree)
    path = root / "wiithrow-cache"
    path.mkdir(exist_ok=True)
    saved = os.environ.get("WIITHROW_CACHE_DIR")
    os.environ["WIITHROW_CACHE_DIR"] = str(path)
    yield path
    if saved is None:
        os.environ.pop("WIITHROW_CACHE_DIR", None)
    else:
        os.environ["WIITHROW_CACHE_DIR"] = saved


@pytest.fixture(autouse=True)
def sim_libraries(tmp_path_factory, monkeypatch):
    """Each test's simulated worlds keep their library folders in a folder of its own
    (`wiithrow.app.session.library_folder.SIM_LIBRARIES_ENV`): a library one test trains or learns
    is never the library in use of another's `throw --sim`."""
    from wiithrow.app.session.library_folder import SIM_LIBRARIES_ENV

    path = tmp_path_factory.mktemp("sim-libraries")
    monkeypatch.setenv(SIM_LIBRARIES_ENV, str(path))
    return path


@pytest.fixture(scope="session", autouse=True)
def zenoh_local_port():
    """The suite's own local meeting port for Zenoh (see the module docstring); child processes inherit it."""
    import socket

    from wiithrow.app.network.zenoh_session import LOCAL_PORT_ENV

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = int(s.getsockname()[1])
    saved = os.environ.get(LOCAL_PORT_ENV)
    os.environ[LOCAL_PORT_ENV] = str(port)
    yield port
    if saved is None:
        os.environ.pop(LOCAL_PORT_ENV, None)
    else:
        os.environ[LOCAL_PORT_ENV] = saved


@pytest.fixture(scope="session", autouse=True)
def zenoh_secret(tmp_path_factory):
    """The suite's own secret file for signed frames (see the module docstring)."""
    from wiithrow.app.network.frame_auth import SECRET_FILE_ENV

    path = tmp_path_factory.mktemp("zenoh-secret") / "secret"
    saved = os.environ.get(SECRET_FILE_ENV)
    os.environ[SECRET_FILE_ENV] = str(path)
    yield path
    if saved is None:
        os.environ.pop(SECRET_FILE_ENV, None)
    else:
        os.environ[SECRET_FILE_ENV] = saved


#: How long a dashboard page may take to start (its Stop button shown), in ms: software WebGL on a
#: loaded 2-core machine took 82 s for a third page at a load of 10 (2026-12-02).
PAGE_START_MS = 240_000

#: Calibration poses of the test dashboard (the fewest that leave-one-out can cross-validate, plus one).
TEST_POSES = 8


#: The browser tests' 3D scene as a thumbnail: three.js's canvas and the box it takes its size from.
#: Viser sizes the canvas's drawing buffer from that box, so a rule on the canvas alone only showed it
#: small: Chromium still rendered 960 x 645 pixels of WebGL in software (SwiftShader), at 2-5 frames/s,
#: and the page, which takes the server's messages once per frame, answered a query in 1-8 s (median)
#: during a calibration; with the box 160 x 120 too, 120 x 90 pixels at 14-16 frames/s and 0.1-0.15 s
#: (two pages, load 11-13, 2026-12-02). The scene is still built and updated; `full_scene` in
#: tests/web/test_browser.py switches the rule off where the scene itself is tested.
SMALL_SCENE = (
    "canvas { width: 160px !important; height: 120px !important; }"
    " div:has(> canvas[data-engine]) { width: 160px !important; height: 120px !important; }"
)

#: A browser context's init script: the scene small (`SMALL_SCENE`, in a <style id="small-scene">)
#: from the page's start, not only once a test got to it (a full scene slows the page's own start).
SHRINK_FROM_START = (
    "document.addEventListener('DOMContentLoaded', () => { const e = document.createElement('style');"
    f" e.id = 'small-scene'; e.textContent = {json.dumps(SMALL_SCENE)}; document.head.appendChild(e); }});"
)


#: PLAIN_SCENE: the dashboards of the browser tests draw their scene plain (`Dashboard(plain_scene=True)`,
#: `--plain-scene`: no shadows, no environment map), as a lab's machine without a GPU would be told
#: to: Chromium's GPU process used 91 s of CPU over the 13 browser tests with them, 48 s without them
#: (10 frames/s both, the demo's test with them in both; 2026-12-05). test_browser_demo.py runs
#: `wiithrow demo` as a person does, with its default scene.

#: The fewest milliseconds between two frames of a test page (`FEWER_FRAMES`): 5 frames/s. The four
#: browser modules on a quiet machine (13 passed in 125 s both ways, 2026-12-05): Chromium's processes
#: used 86 s of CPU at 10 frames/s (the GPU process 45), 73 s at 5 (the GPU process 33).
FRAME_PERIOD_MS = 200

#: A browser context's init script: every `requestAnimationFrame` callback of a frame runs together,
#: in one real frame at most every `FRAME_PERIOD_MS` (all of them, in the order they were asked for;
#: `cancelAnimationFrame` still cancels one). Software WebGL costs the GPU process about 50 ms of CPU
#: per frame of the dashboard, whatever the canvas's size (its draw calls, not its pixels: hiding
#: every node of the scene left a third of it), and viser draws a frame at each scene update (the
#: markers 14 times a second while it tracks): Chromium took 1.6 cores of the two on a calibrated
#: dashboard at rest, 0.4 with this (10 s windows, 2026-12-05), and the browser phase of the suite
#: used 87 % of the machine. The page's logic is the same, its messages handled once per frame as
#: before: at 5 frames/s, within 0.2 s. (Delaying each callback by a timeout of its own made more
#: frames, not fewer.)
FEWER_FRAMES = f"""(() => {{
  const nextFrame = window.requestAnimationFrame.bind(window);
  let waiting = [], asked = false, last = 0, id = 0;
  const run = (t) => {{
    asked = false; last = performance.now();
    const callbacks = waiting; waiting = [];
    for (const [, callback] of callbacks) {{
      try {{ callback(t); }} catch (error) {{ setTimeout(() => {{ throw error; }}); }}  // as a frame: the others still run
    }}
  }};
  window.requestAnimationFrame = (callback) => {{
    waiting.push([++id, callback]);
    if (!asked) {{
      asked = true;
      setTimeout(() => nextFrame(run), Math.max(0, last + {FRAME_PERIOD_MS} - performance.now()));
    }}
    return id;
  }};
  window.cancelAnimationFrame = (cancelled) => {{ waiting = waiting.filter(([i]) => i !== cancelled); }};
}})();"""


def small_scene_context(chromium, **options) -> object:
    """A new browser context (1280 x 860 unless told) whose pages show the scene small from their
    start and draw at most `FRAME_PERIOD_MS` apart (`FEWER_FRAMES`)."""
    context = chromium.new_context(**{"viewport": {"width": 1280, "height": 860}, **options})
    context.add_init_script(SHRINK_FROM_START)
    context.add_init_script(FEWER_FRAMES)
    return context


def wait_for(
    condition: Callable[[], object],
    timeout_s: float,
    what: str,
    period_s: float = 0.05,
    explain: Callable[[], str] | None = None,
):
    """Poll `condition` until it returns something true; fail the test after `timeout_s` (saying
    `explain()` too: the state that kept the condition false)."""
    end = time.monotonic() + timeout_s
    while True:
        value = condition()
        if value:
            return value
        if time.monotonic() > end:
            pytest.fail(f"timed out after {timeout_s:.0f} s waiting for {what}" + (f": {explain()}" if explain else ""))
        time.sleep(period_s)


def _require_browser() -> None:
    from wiithrow.web.browser import chromium_problem

    problem = chromium_problem()
    if not problem:
        return
    if os.environ.get(REQUIRE_BROWSER) == "1":
        pytest.fail(f"the browser tests are mandatory here ({REQUIRE_BROWSER}=1) but {problem}", pytrace=False)
    pytest.skip(f"browser test skipped: {problem}")


@pytest.fixture(scope="module")
def chromium() -> Iterator[object]:
    """A headless Chromium (Playwright Browser), one per browser module (a launch takes about a
    second): each test opens its own contexts (pages) on it and closes them. Not one per worker:
    Playwright's sync API keeps an asyncio loop running in the worker's thread while it is open, and
    a module the worker runs after the browser modules could not call `asyncio.run`."""
    _require_browser()
    from playwright.sync_api import sync_playwright

    from wiithrow.web.browser import launch

    with sync_playwright() as playwright:
        browser = launch(playwright)
        try:
            yield browser
        finally:
            browser.close()


@pytest.fixture(scope="module")
def live_dashboard(chromium) -> Iterator[object]:
    """The demo system with its dashboard on a free port, calibrated; stopped at the end."""
    from wiithrow.app.session import demo_target_base, simulated_session
    from wiithrow.web.server import Dashboard

    session = simulated_session(seed=0, calibration=None, realtime=True, quiet=True)
    session.set_target(demo_target_base())
    dashboard = Dashboard(session, port=0, default_poses=TEST_POSES, plain_scene=True)  # `PLAIN_SCENE`
    dashboard.start()
    try:
        assert dashboard.start_calibration(TEST_POSES)
        yield dashboard
    finally:
        session.stop()
        dashboard.runner.join(timeout=10.0)
        dashboard.close()
        session.close()


@pytest.fixture(scope="module")
def browser_pages(chromium, live_dashboard) -> Iterator[list[object]]:
    """Two operators' browsers (Playwright pages in separate contexts: two clients for the server)
    on the dashboard's operator link, the scene small from their start (`SMALL_SCENE`), opened while
    the calibration runs (software WebGL makes a page take seconds to start); returned once both show
    their panel and the rig is calibrated."""
    contexts = [small_scene_context(chromium) for _ in range(2)]
    pages = [context.new_page() for context in contexts]
    try:
        for page in pages:
            page.goto(live_dashboard.operator_url)
        for page in pages:
            page.get_by_role("button", name="Stop", exact=True).wait_for(timeout=PAGE_START_MS)
        session = live_dashboard.session
        wait_for(lambda: session.calibration_result is not None and not session.busy, 120.0, "the calibration")
        yield pages
    finally:
        for context in contexts:
            context.close()
