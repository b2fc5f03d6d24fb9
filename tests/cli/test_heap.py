"""`wiithrow.app.cli.heap`: while a session serves, what start-up built is frozen out of the
collector's passes (and back after), and the passes over a window are counted and timed."""

from __future__ import annotations

import gc

from wiithrow.app.cli.heap import CollectionPauses, frozen_heap


class _Cycle:
    def __init__(self) -> None:
        self.me = self


def test_the_start_ups_objects_are_frozen_while_serving_and_given_back_after():
    assert gc.get_freeze_count() == 0
    kept = [_Cycle() for _ in range(1000)]
    with frozen_heap() as frozen:
        assert frozen >= len(kept) and gc.get_freeze_count() > 0  # every object alive then, these among them
        walked = {id(o) for o in gc.get_objects(generation=2)}
        assert not any(id(c) in walked for c in kept)
    assert gc.get_freeze_count() == 0
    walked = {id(o) for o in gc.get_objects(generation=2)}
    assert all(id(c) in walked for c in kept)  # walked again by full passes


def test_the_passes_of_a_window_are_counted_per_generation_and_only_in_it():
    pauses = CollectionPauses()
    gc.collect()  # before the window: not counted
    pauses.begin()
    gc.collect(0)
    gc.collect(2)
    gc.collect(2)
    figures = pauses.end()
    assert figures["0"]["count"] == 1 and figures["1"]["count"] == 0 and figures["2"]["count"] == 2
    two = figures["2"]
    assert 0.0 < two["p50_ms"] <= two["max_ms"] <= two["total_ms"]
    assert pauses._callback not in gc.callbacks  # no listening after the window
    gc.collect()
    assert pauses.end()["2"]["count"] == 2  # (the window's figures stay; nothing new was counted)
