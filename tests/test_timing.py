"""The interleaved timing harness (structure only: times are never asserted)."""

import gc

import numpy as np
import pandas as pd
import pytest

from replication.experiments.timing import interleaved, ratio_per_repeat, summarize


def test_interleaved_rotates_the_order_and_counts():
    calls = []
    tasks = {name: (lambda name=name: calls.append(name)) for name in ("a", "b", "c")}
    frame = interleaved(tasks, repeats=4, warmup=2)
    assert len(calls) == 3 * (4 + 2)
    assert calls[6:9] == ["a", "b", "c"] and calls[9:12] == ["b", "c", "a"]  # rotation after warm-up
    assert list(frame.columns) == ["repeat", "task", "position", "seconds"]
    assert frame.groupby("task").size().to_dict() == {"a": 4, "b": 4, "c": 4}
    # each task takes every position in turn
    assert sorted(frame[frame["task"] == "a"]["position"]) == [0, 0, 1, 2]
    assert (frame["seconds"] >= 0).all()


def test_the_collector_is_paused_in_every_task_and_no_full_collection_is_run():
    generations, enabled = [], []

    def record(phase, info):
        if phase == "start":
            generations.append(info["generation"])

    gc.callbacks.append(record)
    try:
        interleaved({"a": lambda: enabled.append(gc.isenabled())}, repeats=3, warmup=1)
    finally:
        gc.callbacks.remove(record)
    assert enabled == [True, False, False, False]  # the warm-up run is not timed
    assert gc.isenabled()
    assert generations and max(generations) < 2  # a full collection costs 0.2 s in a loaded process


def test_interleaved_rejects_bad_counts():
    with pytest.raises(ValueError, match="repeats"):
        interleaved({"a": lambda: None}, repeats=0)


def test_summarize_and_ratio_per_repeat():
    frame = pd.DataFrame(
        {"repeat": [0, 0, 1, 1, 2, 2], "task": ["x", "y"] * 3, "position": 0, "seconds": [2, 1, 4, 1, 9, 3]}
    )
    ratio = ratio_per_repeat(frame, "x", "y")
    np.testing.assert_array_equal(ratio.to_numpy(), [2, 4, 3])
    s = summarize(ratio)
    assert s == {"median": 3.0, "q1": 2.5, "q3": 3.5, "count": 3}
