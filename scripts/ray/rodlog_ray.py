#!/usr/bin/env python3
"""Fan rodlog's heavy work out over a Ray cluster: experiments and fleet replay checks.

    rodlog_ray.py experiment NAME --shards N --out DIR [--address ADDR] [--rodlog BIN]
                  [-- EXPERIMENT OPTIONS...]
    rodlog_ray.py replay-check REC_OR_DIR... --shards N [--address ADDR] [--rodlog BIN]
    rodlog_ray.py overhead [--tasks N] [--address ADDR]

Each shard is a Ray task (one CPU) that runs the `rodlog` binary on its slice:
`rodlog experiment NAME --shard K/N --out DIR/shard-K` or `rodlog replay ... --check
--shard K/N`, with one worker thread (RAYON_NUM_THREADS=1). The driver shows progress as
shards finish, retries a failed shard once, and for an experiment merges the shards with
`rodlog experiment merge`, which recomputes every table from the shards' records.

Ray is only the scheduler: the binary, the recordings and the output folder must be reachable
at the same paths from every worker (the local machine; on Kubernetes, the container image and
a shared volume; see the README's "Running at scale"). By default the driver joins a running
local head (`ray start --head`) or starts a private one; `--address` joins any cluster.
`overhead` measures what Ray adds per task (a no-op task, and a task that starts a process).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import ray

ROOT = Path(__file__).resolve().parents[2]


def default_rodlog() -> str:
    for candidate in (ROOT / "target/release/rodlog", ROOT / "target/debug/rodlog"):
        if candidate.is_file():
            return str(candidate)
    found = shutil.which("rodlog")
    if found:
        return found
    sys.exit("rodlog_ray: no rodlog binary (build it with `cargo build --release` or pass --rodlog)")


@ray.remote(num_cpus=1)
def run_shard(argv: list[str], env_extra: dict[str, str]) -> dict:
    """Runs one shard's command; returns its exit status, output tail and wall time."""
    env = dict(os.environ)
    env.update(env_extra)
    started = time.monotonic()
    done = subprocess.run(argv, capture_output=True, text=True, env=env)
    return {
        "argv": argv,
        "returncode": done.returncode,
        "stdout": done.stdout[-4000:],
        "stderr": done.stderr[-4000:],
        "wall_s": time.monotonic() - started,
        "node": ray.util.get_node_ip_address(),
    }


@ray.remote(num_cpus=1)
def noop() -> float:
    return time.monotonic()


@ray.remote(num_cpus=1)
def start_process(argv: list[str]) -> int:
    return subprocess.run(argv, capture_output=True).returncode


def connect(address: str | None) -> None:
    kwargs = {"include_dashboard": False, "log_to_driver": False}
    if address:
        ray.init(address=address, **kwargs)
    else:
        try:
            ray.init(address="auto", **kwargs)
        except ConnectionError:
            ray.init(num_cpus=os.cpu_count(), **kwargs)
    print(f"ray: {ray.cluster_resources().get('CPU', 0):.0f} CPUs", file=sys.stderr, flush=True)


def fan_out(commands: list[list[str]], label: str) -> list[dict]:
    """Runs every command as a Ray task; each failed one is retried once. Returns the final
    result of each command, in order."""
    env_extra = {"RAYON_NUM_THREADS": "1"}
    pending = {run_shard.remote(c, env_extra): (i, 0) for i, c in enumerate(commands)}
    results: list[dict | None] = [None] * len(commands)
    done_count = 0
    started = time.monotonic()
    while pending:
        ready, _ = ray.wait(list(pending), num_returns=1)
        ref = ready[0]
        i, attempt = pending.pop(ref)
        try:
            r = ray.get(ref)
        except Exception as e:  # a worker that died: Ray's own error
            r = {"argv": commands[i], "returncode": -1, "stdout": "", "stderr": repr(e), "wall_s": float("nan"), "node": "?"}
        if r["returncode"] != 0 and attempt == 0:
            print(f"{label}: shard {i} failed (exit {r['returncode']}), retrying once: {r['stderr'].strip()[-300:]}", file=sys.stderr, flush=True)
            pending[run_shard.remote(commands[i], env_extra)] = (i, 1)
            continue
        results[i] = r
        done_count += 1
        state = "ok" if r["returncode"] == 0 else f"FAILED (exit {r['returncode']})"
        print(
            f"{label}: {done_count}/{len(commands)} shards done (shard {i} {state} in {r['wall_s']:.1f} s on {r['node']}; {time.monotonic() - started:.1f} s elapsed)",
            file=sys.stderr,
            flush=True,
        )
    return [r for r in results if r is not None]


def experiment(args: argparse.Namespace) -> int:
    out = Path(args.out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    shard_dirs = [out / f"shard-{k}" for k in range(args.shards)]
    commands = [
        [args.rodlog, "experiment", args.name, "--shard", f"{k}/{args.shards}", "--out", str(d), *args.rest]
        for k, d in enumerate(shard_dirs)
    ]
    started = time.monotonic()
    results = fan_out(commands, f"experiment {args.name}")
    failed = [r for r in results if r["returncode"] != 0]
    if failed:
        for r in failed:
            print(f"shard failed twice: {' '.join(r['argv'])}\n{r['stderr']}", file=sys.stderr)
        return 1
    merged = subprocess.run(
        [args.rodlog, "experiment", "merge", "--out", str(out), *map(str, shard_dirs)],
        capture_output=True,
        text=True,
    )
    sys.stdout.write(merged.stdout)
    if merged.returncode != 0:
        sys.stderr.write(merged.stderr)
        return merged.returncode
    summary = {
        "experiment": args.name,
        "shards": args.shards,
        "wall_s": time.monotonic() - started,
        "shard_wall_s": [r["wall_s"] for r in results],
        "out": str(out),
    }
    (out / "ray.json").write_text(json.dumps(summary, indent=2) + "\n")
    print(f"experiment {args.name}: {args.shards} shards merged into {out} in {summary['wall_s']:.1f} s", file=sys.stderr)
    return 0


def replay_check(args: argparse.Namespace) -> int:
    recs = [str(Path(r).resolve()) for r in args.recordings]
    commands = [
        [args.rodlog, "replay", *recs, "--check", "--shard", f"{k}/{args.shards}"] for k in range(args.shards)
    ]
    results = fan_out(commands, "replay-check")
    bad = 0
    for k, r in enumerate(results):
        empty_shard = r["returncode"] != 0 and "empty shard" in r["stderr"]
        if r["returncode"] != 0 and not empty_shard:
            bad += 1
            print(f"shard {k}/{args.shards} FAILED:\n{r['stderr']}", file=sys.stderr)
        else:
            passed = r["stdout"].count("check passed")
            print(f"shard {k}/{args.shards}: {passed} recordings passed")
    return 1 if bad else 0


def overhead(args: argparse.Namespace) -> int:
    n = args.tasks
    ray.get([noop.remote() for _ in range(4)])  # warm the workers
    t0 = time.monotonic()
    ray.get([noop.remote() for _ in range(n)])
    per_task_ms = 1e3 * (time.monotonic() - t0) / n
    true_bin = shutil.which("true") or "/bin/true"
    t0 = time.monotonic()
    ray.get([start_process.remote([true_bin]) for _ in range(n)])
    per_process_ms = 1e3 * (time.monotonic() - t0) / n
    t0 = time.monotonic()
    for _ in range(n):
        subprocess.run([true_bin])
    local_process_ms = 1e3 * (time.monotonic() - t0) / n
    print(json.dumps({
        "tasks": n,
        "noop_task_ms": per_task_ms,
        "process_task_ms": per_process_ms,
        "local_process_ms": local_process_ms,
        "ray_overhead_per_process_task_ms": per_process_ms - local_process_ms,
    }, indent=2))
    return 0


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--address", help="Ray cluster address (default: the local head, or a private one)")
    parser.add_argument("--rodlog", default=None, help="the rodlog binary (default: target/release, target/debug, PATH)")
    sub = parser.add_subparsers(dest="job", required=True)
    e = sub.add_parser("experiment", help="one experiment, sharded and merged")
    e.add_argument("name")
    e.add_argument("--shards", type=int, required=True)
    e.add_argument("--out", required=True)
    # The experiment's own options follow `--` (split off before parsing).
    r = sub.add_parser("replay-check", help="replay --check of recordings, sharded")
    r.add_argument("recordings", nargs="+")
    r.add_argument("--shards", type=int, required=True)
    o = sub.add_parser("overhead", help="what Ray adds per task")
    o.add_argument("--tasks", type=int, default=50)
    argv = sys.argv[1:]
    rest: list[str] = []
    if "--" in argv:
        cut = argv.index("--")
        argv, rest = argv[:cut], argv[cut + 1 :]
    args = parser.parse_args(argv)
    args.rest = rest
    if getattr(args, "shards", 1) < 1:
        parser.error("--shards must be at least 1")
    if args.job != "overhead":
        args.rodlog = str(Path(args.rodlog).resolve()) if args.rodlog else default_rodlog()
    connect(args.address)
    try:
        return {"experiment": experiment, "replay-check": replay_check, "overhead": overhead}[args.job](args)
    finally:
        ray.shutdown()


if __name__ == "__main__":
    sys.exit(main())
