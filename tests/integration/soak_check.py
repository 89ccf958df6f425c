#!/usr/bin/env python3
"""The soak's bounds over samples.csv (soak_test.sh); prints every figure, exits 1 on a breach.

  soak_check.py SAMPLES STALL KEEP_CHECKPOINTS CHECKPOINT_BYTES
"""
import csv
import sys
from collections import defaultdict

WARM_UP_S = 120        # a process's first two minutes: libraries load, arenas and queues fill
GROWTH_PER_HOUR = 0.05
NOISE_KB = 8 * 1024    # allocator noise allowed on top of the growth bound
RESTART_SPREAD = 0.15  # a restarted process's memory at the same age, against its first life
STALL_KB = 64 * 1024   # the broker's and actors' memory while the learner is stopped

samples_path, stall_path, keep, checkpoint = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4])
rows = list(csv.DictReader(open(samples_path)))
for r in rows:
    for k in ("t", "life", "age", "rss_kb", "fds", "threads", "run_bytes", "log_bytes"):
        r[k] = int(r[k])
breaches = []

lives = defaultdict(list)  # (role, life) -> rows past the warm-up, in time order
for r in rows:
    if r["age"] >= WARM_UP_S and r["phase"] == "run":
        lives[(r["role"], r["life"])].append(r)

print("role     life  samples  minutes  rss MB first -> last  growth %/h  fds  threads")
for (role, life), rs in sorted(lives.items()):
    first, last = rs[0], rs[-1]
    hours = (last["t"] - first["t"]) / 3600
    growth = last["rss_kb"] - first["rss_kb"]
    per_hour = growth / first["rss_kb"] / hours * 100 if hours > 0 else 0.0
    print(f"{role:8} {life:4}  {len(rs):7}  {hours * 60:7.1f}  {first['rss_kb'] / 1024:7.1f} -> "
          f"{last['rss_kb'] / 1024:7.1f}  {per_hour:10.2f}  {first['fds']}->{last['fds']}  "
          f"{first['threads']}->{last['threads']}")
    allowed = first["rss_kb"] * GROWTH_PER_HOUR * hours + NOISE_KB
    if growth > allowed:
        breaches.append(f"{role} life {life}: memory grew {growth} kB in {hours * 60:.1f} min "
                        f"(bound {allowed:.0f} kB)")
    peak_fds = max(r["fds"] for r in rs)
    if peak_fds > first["fds"] + 5:
        breaches.append(f"{role} life {life}: descriptors {first['fds']} -> {peak_fds}")
    peak_threads = max(r["threads"] for r in rs)
    if peak_threads > first["threads"] + 2:
        breaches.append(f"{role} life {life}: threads {first['threads']} -> {peak_threads}")

# Restarts: each life's first sample past the warm-up against the role's first life's.
first_of = defaultdict(dict)
for (role, life), rs in lives.items():
    first_of[role][life] = rs[0]["rss_kb"]
for role, by_life in sorted(first_of.items()):
    base = by_life[min(by_life)]
    figures = ", ".join(f"life {l}: {kb / 1024:.1f} MB" for l, kb in sorted(by_life.items()))
    print(f"{role} after warm-up: {figures}")
    for l, kb in by_life.items():
        if abs(kb - base) > RESTART_SPREAD * base:
            breaches.append(f"{role} life {l}: {kb} kB after warm-up, the first life {base} kB")

# Disk: checkpoints within (keep + 1) x their size (one more while the next is written).
peak = max(rows, key=lambda r: r["run_bytes"] - r["log_bytes"])
held = peak["run_bytes"] - peak["log_bytes"]
bound = (keep + 1) * checkpoint + 64 * 1024
print(f"run folder: at most {held / 1e6:.2f} MB besides its logs "
      f"(bound {(keep + 1)} x {checkpoint / 1e6:.2f} MB); logs {rows[-1]['log_bytes'] / 1e3:.0f} kB at the end")
if held > bound:
    breaches.append(f"run folder holds {held} bytes besides logs, bound {bound}")

# The stall: memory of the broker and actors while the learner was stopped, against before it.
stall = [r for r in rows if r["phase"] == "stall"]
if stall:
    t_stall = stall[0]["t"]
    for role in ("broker", "actor-0", "actor-1"):
        before = [r for r in rows if r["role"] == role and r["t"] < t_stall and r["phase"] == "run"]
        during = [r for r in stall if r["role"] == role]
        if not before or not during:
            continue
        base = before[-1]["rss_kb"]
        peak_kb = max(r["rss_kb"] for r in during)
        print(f"{role} while the learner was stopped: {base / 1024:.1f} MB before, "
              f"at most {peak_kb / 1024:.1f} MB")
        if peak_kb > base + STALL_KB:
            breaches.append(f"{role}: {peak_kb} kB while the learner was stopped, {base} kB before")
    idle_before, idle_after, unf_before, unf_after, stale_before, stale_after, resumed = (
        int(x) for x in open(stall_path).read().split(","))
    dropped = (unf_after - unf_before) + (stale_after - stale_before)
    print(f"learner stopped 60 s: actor-0 waited {idle_after - idle_before} s of it; the broker "
          f"dropped {unf_after - unf_before} segments meanwhile, the learner "
          f"{stale_after - stale_before} stale ones after it; a new policy {resumed} s after SIGCONT")
    if dropped <= 0:
        breaches.append("no segment counted as dropped while the learner was stopped: where did "
                        "60 s of the actors' segments go?")
else:
    breaches.append("no samples while the learner was stopped")

for b in breaches:
    print("BREACH:", b)
sys.exit(1 if breaches else 0)
