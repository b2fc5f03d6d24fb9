"""What `RemoteRig` counts and tells the operator: `RemoteNotices`.

The refusals by reason (`refused`, in `marker_checks.REASONS`' order: what the rig refused before
its queue, as `Subscription` counted it, and after), and the notices: one line each, collected
under the rig's lock (`tell`) and handed over once it is released (`take`). The refusals are summed
up at most every `NOTICE_EVERY_S` on the arrival clock (`summarise`): their counts by reason, the
first one's detail, how many waiting frames a full queue dropped unread, and, when frames came
unsigned, where this user's secret is (a publisher on another host signs with a copy of it).
"""

from __future__ import annotations

from collections import Counter

from wiithrow.app.network.frame_auth import secret_path
from wiithrow.app.network.marker_checks import REASONS

#: The refusals are summed up for the operator at most this often (s, arrival clock).
NOTICE_EVERY_S = 5.0


class RemoteNotices:
    """The refusals and notices of the markers under `prefix` (see the module docstring);
    `max_queued`: the queue's bound, said when it dropped frames."""

    def __init__(self, prefix: str, max_queued: int) -> None:
        self.prefix = prefix
        self.max_queued = max_queued
        self.refused: Counter[str] = Counter()
        self._since_summary: Counter[str] = Counter()
        self._first = ""
        self._last_summary = -float("inf")
        self._pending: list[str] = []

    def count(self, reason: str, count: int, detail: str, *, summarised: bool = True) -> None:
        """`count` frames refused as `reason`; `detail` says why (kept for the first of a summary).
        `summarised=False`: counted, but left out of the summary line (a publisher waiting for the
        operator's confirmation, which its offer's notice and the dashboard already say)."""
        self.refused[reason] += count
        if not summarised:
            return
        self._since_summary[reason] += count
        if not self._first:
            self._first = f"{reason}: {detail}"

    def tell(self, notice: str) -> None:
        self._pending.append(notice)

    def take(self) -> list[str]:
        """The notices told since the last call, in order."""
        notices, self._pending = self._pending, []
        return notices

    def summarise(self, now: float) -> None:
        """Tell one line for the refusals since the last one, at most every NOTICE_EVERY_S."""
        since = self._since_summary
        if not since or now - self._last_summary < NOTICE_EVERY_S:
            return
        counts = ", ".join(f"{since[r]} {r}" for r in REASONS if since[r])
        text = f"markers from {self.prefix}: refused {sum(since.values())} frames ({counts}); first: {self._first}"
        if since["queue_full"]:
            text += f"; {since['queue_full']} dropped unread: more than {self.max_queued} waited"
        if since["unauthenticated"]:
            text += (
                f"; unsigned or signed with another secret: a publisher on another host signs with a copy of this "
                f"user's secret ({secret_path()})"
            )
        self.tell(text)
        since.clear()
        self._first = ""
        self._last_summary = now

    def counts(self) -> str:
        """The refusals so far, e.g. "3 other_source, 1 malformed" ("none")."""
        return ", ".join(f"{self.refused[r]} {r}" for r in REASONS if self.refused[r]) or "none"
