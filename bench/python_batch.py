#!/usr/bin/env python3
"""Python batch benchmark (issue 15): isowrench.Model.wrench_batch on 100,000 postures against
(a) the C++ batch (EvaluateBatch) timed by the CLI's `isowrench sweep --json` (compute_seconds:
the same postures, one stiffness set, same thread count) and (b) a Python loop of Model.wrench.

    PYTHONPATH=build/python python3 bench/python_batch.py [--cli build/isowrench] [--threads 2]

Prints ns per posture for each and the two ratios the issue bounds: wrench_batch / C++ batch
(<= ~2) and Python loop / wrench_batch (>= 20). Each timing is the best of --repeat runs.
"""

import argparse
import json
import pathlib
import subprocess
import sys
import tempfile
import time

import numpy as np

import isowrench

REPO = pathlib.Path(__file__).resolve().parents[1]


def grid(from_deg, to_deg, step_deg):
    count = int(round((to_deg - from_deg) / step_deg)) + 1
    return np.radians(from_deg + step_deg * np.arange(count))


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--urdf", default=str(REPO / "urdf" / "rat_hindlimb_5dof.urdf"))
    parser.add_argument("--muscle", default="GP")
    parser.add_argument("--cli", default=str(pathlib.Path(isowrench.__file__).resolve().parents[2] / "isowrench"))
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--loop", type=int, default=5000, help="postures timed in the Python loop")
    args = parser.parse_args()

    m = isowrench.load(args.urdf)
    # hip_rz -150..-50 deg step 0.3 (334 values) x knee_rz 0..150 deg step 0.5 (301): 100,534 postures.
    hip, knee = grid(-150, -50, 0.3), grid(0, 150, 0.5)
    Q = np.tile(m.default_posture, (hip.size * knee.size, 1))
    Q[:, m.coordinates.index("hip_rz")] = np.repeat(hip, knee.size)
    Q[:, m.coordinates.index("knee_rz")] = np.tile(knee, hip.size)
    N = Q.shape[0]

    best = float("inf")
    for _ in range(args.repeat):
        t = time.perf_counter()
        W = m.wrench_batch(args.muscle, Q, threads=args.threads)
        best = min(best, time.perf_counter() - t)
    batch_ns = best * 1e9 / N

    cpp_ns = None
    if pathlib.Path(args.cli).exists():
        cpp = float("inf")
        with tempfile.TemporaryDirectory() as tmp:
            for _ in range(args.repeat):
                out = subprocess.run([args.cli, "sweep", args.urdf, "--muscle", args.muscle,
                                      "--grid", "hip_rz=-150:-50:0.3", "--grid", "knee_rz=0:150:0.5",
                                      "--threads", str(args.threads), "-o", str(pathlib.Path(tmp) / "sweep.csv"),
                                      "--json"], capture_output=True, text=True, check=True)
                report = json.loads(out.stdout)
                assert report["postures"] == N, (report["postures"], N)
                cpp = min(cpp, report["compute_seconds"])
        cpp_ns = cpp * 1e9 / N

    idx = np.linspace(0, N - 1, min(args.loop, N)).astype(int)
    t = time.perf_counter()
    single = np.array([m.wrench(args.muscle, Q[i]).transducer for i in idx])
    loop_ns = (time.perf_counter() - t) * 1e9 / idx.size
    scale = np.abs(single).max(axis=1, keepdims=True)
    agreement = float(np.max(np.abs(W[idx] - single) / np.maximum(scale, 1e-300)))

    print(f"isowrench {isowrench.__version__}: {m.name}, muscle {args.muscle}, {N} postures, "
          f"{args.threads} threads, best of {args.repeat}")
    print(f"  wrench_batch (Python)          {batch_ns:10.1f} ns per posture   ({best * 1e3:.1f} ms total)")
    if cpp_ns is not None:
        print(f"  C++ EvaluateBatch (CLI sweep)  {cpp_ns:10.1f} ns per posture")
    print(f"  Python loop of Model.wrench    {loop_ns:10.1f} ns per posture   ({idx.size} postures timed)")
    if cpp_ns is not None:
        print(f"  wrench_batch / C++ batch       {batch_ns / cpp_ns:10.2f} x   (issue bound: <= ~2)")
    print(f"  Python loop / wrench_batch     {loop_ns / batch_ns:10.0f} x   (issue bound: >= 20)")
    print(f"  max |W_batch - W_single| / |W_single|_inf = {agreement:.2e}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
