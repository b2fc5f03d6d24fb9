"""What `wiithrow check-driver` found: one `CheckResult` per check (pass, fail or not run, the
reason in one line, the measured figures and the bounds they were judged by) and the
`DriverReport` of them all, as a table for the terminal and as a versioned JSON document.

A report passes only when every check ran and passed: a check that could not run (no hand named,
no throw library for the arm, no calibrated rig to watch the arm, a probe that the arm's failure
cut short) is not a pass. A check that passed may carry warnings (one line each: what it found
that a driver may have a reason for, and what it risks); the table shows it as WARN, the JSON as
"pass" with its "warnings".
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Literal

from wiithrow.app.tables import format_table

#: The report file's kind and schema version (`wiithrow.vision.files.write_versioned_json`).
REPORT_KIND = "wiithrow.driver-report"
REPORT_SCHEMA = 1

Status = Literal["pass", "fail", "not run"]


@dataclass(frozen=True)
class CheckResult:
    """One check: `name`, `status`, `reason` (one line: what was measured against what, or why it
    did not run), `figures` (measured, SI units, names carry them), `bounds` (the same keys) and
    `warnings` (one line each, on a check that passed: see the module docstring)."""

    name: str
    status: Status
    reason: str
    figures: dict[str, Any] = field(default_factory=dict)
    bounds: dict[str, Any] = field(default_factory=dict)
    warnings: tuple[str, ...] = ()

    @property
    def passed(self) -> bool:
        return self.status == "pass"

    def to_dict(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "status": self.status,
            "passed": self.passed,
            "reason": self.reason,
            "figures": self.figures,
            "bounds": self.bounds,
            "warnings": list(self.warnings),
        }


def judged(
    name: str,
    figures: dict[str, Any],
    bounds: dict[str, Any],
    failures: list[str],
    summary: str,
    warnings: list[str] | None = None,
) -> CheckResult:
    """A check that ran: failed with the `failures` (each a reason) joined, else passed with
    `summary` and the `warnings` (kept either way)."""
    if failures:
        return CheckResult(name, "fail", "; ".join(failures), figures, bounds, tuple(warnings or ()))
    return CheckResult(name, "pass", summary, figures, bounds, tuple(warnings or ()))


def not_run(name: str, why: str) -> CheckResult:
    return CheckResult(name, "not run", why)


@dataclass(frozen=True)
class DriverReport:
    """The checks of one arm driver (and hand driver) as the settings name them."""

    arm: str
    arm_driver: str
    gripper_driver: str
    clock: str  # "system" (real time, as serve runs the drivers) or "simulated"
    checks: tuple[CheckResult, ...]
    created_utc: str = ""
    settings_file: str | None = None

    @property
    def passed(self) -> bool:
        return bool(self.checks) and all(c.passed for c in self.checks)

    def failed(self) -> list[CheckResult]:
        """The checks that failed or did not run."""
        return [c for c in self.checks if not c.passed]

    def check(self, name: str) -> CheckResult:
        for c in self.checks:
            if c.name == name:
                return c
        raise KeyError(name)

    def to_dict(self) -> dict[str, Any]:
        return {
            "passed": self.passed,
            "arm": self.arm,
            "arm_driver": self.arm_driver,
            "gripper_driver": self.gripper_driver,
            "clock": self.clock,
            "created_utc": self.created_utc,
            "settings_file": self.settings_file,
            "checks": [c.to_dict() for c in self.checks],
        }

    def warnings(self) -> list[str]:
        """Every check's warnings, each prefixed with its check's name."""
        return [f"{c.name}: {w}" for c in self.checks for w in c.warnings]

    def table(self) -> str:
        """The checks as a table: name, PASS/WARN/FAIL/NOT RUN, reason (and each warning)."""
        rows = [
            (c.name, "WARN" if c.passed and c.warnings else c.status.upper(), "; ".join([c.reason, *c.warnings]))
            for c in self.checks
        ]
        verdict = "PASSED" if self.passed else f"FAILED ({', '.join(c.name for c in self.failed())})"
        if self.warnings():
            verdict += f", {len(self.warnings())} warning(s)"
        head = f"arm driver {self.arm_driver or '-'} ({self.arm}), hand {self.gripper_driver or '-'}: {verdict}"
        return head + "\n" + format_table(["check", "result", "why"], rows)
