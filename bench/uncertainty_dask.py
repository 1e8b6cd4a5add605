"""isowrench.study on Dask against local threads (issue 30, docs/performance.md "Uncertainty
studies"): one stiffness-only study of about EVALUATIONS engine evaluations (default 1e8) run in
turn on 2 local threads, on a LocalCluster of 2 worker processes (1 thread each) and on a
LocalCluster of 1 worker, ROUNDS times (default 2), each run timed from submission to the merged
result (cluster start-up excluded), then the medians and the ratios of each round's pair.

    PYTHONPATH=build/python /usr/bin/python3 bench/uncertainty_dask.py [EVALUATIONS] [ROUNDS]
"""

import os
import statistics
import sys
import time

import isowrench
import isowrench.study as study
from dask.distributed import Client, LocalCluster

HERE = os.path.dirname(os.path.abspath(__file__))
EVALUATIONS = float(sys.argv[1]) if len(sys.argv) > 1 else 1e8
ROUNDS = int(sys.argv[2]) if len(sys.argv) > 2 else 2
INPUTS = [f"transducer_stiffness:{d}=lognormal:0.5" for d in ("x", "y", "z", "rx", "ry", "rz")]
SAMPLES = int(EVALUATIONS / (len(INPUTS) + 2))


def main():
    model = isowrench.load(os.path.join(HERE, "..", "urdf", "rat_hindlimb_5dof.urdf"))
    args = dict(inputs=INPUTS, samples=SAMPLES)
    times = {"local 2 threads": [], "LocalCluster 2 workers": [], "LocalCluster 1 worker": []}
    results = {}
    with LocalCluster(n_workers=2, threads_per_worker=1, host="127.0.0.1", dashboard_address="127.0.0.1:0",
                      silence_logs=50) as c2, Client(c2) as client2, \
            LocalCluster(n_workers=1, threads_per_worker=1, host="127.0.0.1", dashboard_address="127.0.0.1:0",
                         silence_logs=50) as c1, Client(c1) as client1:
        for _ in range(ROUNDS):
            for name, kwargs in (("local 2 threads", dict(threads=2)),
                                 ("LocalCluster 2 workers", dict(client=client2)),
                                 ("LocalCluster 1 worker", dict(client=client1))):
                start = time.perf_counter()
                r = study.uncertainty(model, "GP", **args, **kwargs)
                times[name].append(time.perf_counter() - start)
                results[name] = {k: v for k, v in r.items() if k != "seconds"}
    evaluations = r["evaluations"]
    print(f"{evaluations:.4g} evaluations ({SAMPLES} samples x {len(INPUTS) + 2} rows), "
          f"{ROUNDS} rounds, load average {os.getloadavg()[0]:.1f}")
    for name, t in times.items():
        print(f"  {name:24s} median {statistics.median(t):7.2f} s  "
              f"{evaluations / statistics.median(t) / 1e6:6.2f} M evaluations/s  ({', '.join(f'{x:.2f}' for x in t)})")
    local, two, one = (times[k] for k in times)
    print("  2 workers / local threads (rate):", ", ".join(f"{l / w:.3f}" for l, w in zip(local, two)))
    print("  2 workers / 1 worker (rate):     ", ", ".join(f"{o / w:.3f}" for o, w in zip(one, two)))
    same = all(results[k] == results["local 2 threads"] for k in results)
    print("  results identical on all three:", same)


if __name__ == "__main__":
    main()
