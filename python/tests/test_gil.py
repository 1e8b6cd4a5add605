"""wrench_batch releases the GIL: another Python thread runs while the batch runs."""

import threading
import time

import numpy as np


def test_second_thread_progresses_during_batch(rat):
    Q = np.tile(rat.default_posture, (1_000_000, 1))
    Q[:, 3] += np.linspace(-0.5, 0.5, Q.shape[0])
    window = {}

    def batch():
        window["start"] = time.perf_counter()
        rat.wrench_batch("GP", Q, threads=1)
        window["end"] = time.perf_counter()

    worker = threading.Thread(target=batch)
    ticks = []
    worker.start()
    while worker.is_alive():
        ticks.append(time.perf_counter())
    worker.join()
    inside = [t for t in ticks if window["start"] < t < window["end"]]
    duration = window["end"] - window["start"]
    # A C++ call that holds the GIL never lets this thread run: no tick at all would fall inside
    # the batch. No bound on the batch's own duration (speed is not a unit-test property); ticks
    # take ~0.1 us each, so 1000 of them need only a batch of a fraction of a millisecond.
    assert len(inside) > 1000, (len(inside), duration)
    middle = [t for t in inside if window["start"] + 0.25 * duration < t < window["end"] - 0.25 * duration]
    assert len(middle) > 100, (len(middle), duration)
