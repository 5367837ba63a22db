#!/usr/bin/env python3
"""Throughput of btfpt.Btf.eval (the Python module's batched PLM-C evaluation) on N random
queries: uniform uv, view and light directions uniform on the upper hemisphere.

usage: scripts/bench_python_eval.py MODEL.plmc [--queries 1000000] [--runs 15]

Prints the median, min and max wall time of Btf.eval over the runs and the queries per second
of the median, with the rayon thread count (RAYON_NUM_THREADS, default all cores). The first
call is a warm-up and not counted. The 256² PLM-C model of the benches (random clusters and
indices: a real model's cache behaviour at its worst):
    cargo run --release --example bench_plmc_model -- 256 /tmp/bench256.plmc
Also prints the process CPU time of the median run (all threads), the figure a loaded machine
does not distort much.
"""
import argparse
import os
import statistics
import time

import numpy as np

import btfpt


def hemisphere(rng, n):
    v = rng.normal(size=(n, 3))
    v[:, 2] = np.abs(v[:, 2])
    return (v / np.linalg.norm(v, axis=1, keepdims=True)).astype(np.float32)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("model")
    ap.add_argument("--queries", type=int, default=1_000_000)
    ap.add_argument("--runs", type=int, default=15)
    args = ap.parse_args()
    btf = btfpt.Btf.open(args.model)
    rng = np.random.default_rng(1)
    n = args.queries
    uv = rng.random((n, 2)).astype(np.float32)
    wi, wo = hemisphere(rng, n), hemisphere(rng, n)
    btf.eval(uv, wi, wo)
    times, cpus = [], []
    for _ in range(args.runs):
        t0, c0 = time.perf_counter(), time.process_time()
        btf.eval(uv, wi, wo)
        times.append(time.perf_counter() - t0)
        cpus.append(time.process_time() - c0)
    med = statistics.median(times)
    threads = os.environ.get("RAYON_NUM_THREADS", f"all {os.cpu_count()} cores")
    print(f"{btf!r}")
    print(f"Btf.eval, {n} queries, {args.runs} runs, threads: {threads}")
    print(f"median {med * 1e3:.1f} ms (min {min(times) * 1e3:.1f}, max {max(times) * 1e3:.1f}): "
          f"{n / med / 1e6:.2f} M queries/s; CPU {statistics.median(cpus) * 1e9 / n:.1f} ns per query "
          f"(median over runs, all threads)")


if __name__ == "__main__":
    main()
