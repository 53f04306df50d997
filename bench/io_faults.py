#!/usr/bin/python3
"""Every I/O call of a short session failed once (issue 58): a 2-s session of two simulated cameras and
the Sensel is recorded with tests/io_faults/io_faults.c preloaded, first counting its write, fsync,
rename and read calls on the session's files, then once for every N (or every STRIDE-th) with the N-th
call of one kind failing: EIO (and ENOSPC for writes). Each run must end with exit 1 and an error line
naming the file and the error; then `pvcap recover` and `pvcap verify` must find nothing damaged (exit
0 or 3, no ERROR). Prints one line per kind and every run that broke the rule; exit 0 when none did.

    python3 bench/io_faults.py [--ops write,fsync,rename,read] [--what eio-once,enospc-once] [--stride K] [--seed S]

Needs root (the simulated rig's network namespace) and a build (bash scripts/build.sh). Removes what it
records.
"""
import argparse
import os
import random
import re
import shutil
import subprocess
import sys
import tempfile
import time

HERE = os.path.abspath(os.path.join(os.path.dirname(__file__), ".."))
PVCAP = os.path.join(HERE, "build/app/pvcap")
LIB = os.path.join(HERE, "build/tests/libpvcap_io_faults.so")
ERRORS = re.compile(r"Input/output error|disk I/O error|No space left on device|database or disk is full|"
                    r"malformed")


def rig_yaml():
    cams = "".join(
        f"  - name: cam{i}\n    serial: PVSIM{i}\n    address: 127.0.0.{i + 2}\n    width: 320\n    height: 240\n"
        f"    frame_rate: 30\n    packet_size: 8192\n    trigger: free-run\n" for i in range(2))
    sims = "".join("    - {clock_offset_ms: 0, drift_ppm: 0, jitter_us: 10, packet_loss: 0}\n" for _ in range(2))
    return (f"name: test-rig\ncameras:\n{cams}sensel:\n  tty: sim\n  scan_detail: medium\nstore:\n  video_fps: 15\n"
            f"  preset: ultrafast\n  segment_seconds: 1\nsim:\n  seed: 11\n"
            f"  sensel: {{press_x_mm: 100, press_y_mm: 60, peak_grams: 250, period_s: 1.0}}\n  cameras:\n{sims}")


def session(work, fault, count_file=None):
    """Records one session under `fault`; returns (exit code, output, session folder or None)."""
    root = os.path.join(work, "s")
    shutil.rmtree(root, ignore_errors=True)
    env = dict(os.environ, LD_PRELOAD=LIB, PVCAP_IO_FAULT=fault, PVCAP_IO_FAULT_ROOT=root)
    if count_file:
        env["PVCAP_IO_FAULT_COUNT"] = count_file
    p = subprocess.run([PVCAP, "session", "--rig", os.path.join(work, "rig.yaml"), "--root", root, "--duration",
                        "2", "--no-web"], env=env, capture_output=True, text=True)
    folders = [os.path.join(root, d) for d in os.listdir(root) if not d.startswith(".")] if os.path.isdir(root) else []
    return p.returncode, p.stdout + p.stderr, folders[0] if folders else None


def judge(code, out, folder):
    """'' when the run kept the rule, else why not; None when the fault never fired."""
    fired = re.search(r"io_faults: \w+ #\d+ of (\S+) failed with (\w+)", out)
    if not fired:
        return None
    name = os.path.basename(fired.group(1))
    names = {name, "session.db" if name.startswith("session.db") else name}
    errors = [l for l in out.splitlines() if "error]" in l]
    if code != 1:
        return f"exit {code}"
    if not any(ERRORS.search(l) and any(n in l for n in names) for l in errors):
        return "no error line names " + name + ": " + (errors[0][:200] if errors else "(none)")
    if folder:
        r = subprocess.run([PVCAP, "--log-level", "warn", "recover", folder], capture_output=True, text=True)
        if r.returncode != 0:
            return f"recover exit {r.returncode}: {(r.stdout + r.stderr)[-200:]}"
        v = subprocess.run([PVCAP, "--log-level", "off", "verify", folder], capture_output=True, text=True)
        if v.returncode not in (0, 3) or "ERROR" in v.stdout:
            return f"verify exit {v.returncode}: {v.stdout[-300:]}"
    return ""


def main():
    a = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    a.add_argument("--ops", default="write,fsync,rename,read")
    a.add_argument("--stride", type=int, default=1, help="try every STRIDE-th N (1: every one)")
    a.add_argument("--seed", type=int, default=None, help="with --stride > 1, where the first N falls")
    a.add_argument("--what", default="eio-once,enospc-once",
                   help="the failures to try (a write tries each; other calls only eio-once)")
    args = a.parse_args()
    for f in (PVCAP, LIB):
        if not os.path.exists(f):
            sys.exit(f"{f}: not built; run bash scripts/build.sh first")
    seed = args.seed if args.seed is not None else random.randrange(1 << 30)
    work = tempfile.mkdtemp(prefix="pvcap-io-faults-")
    broken = 0
    started = time.time()
    try:
        with open(os.path.join(work, "rig.yaml"), "w") as f:
            f.write(rig_yaml())
        count_file = os.path.join(work, "count.txt")
        session(work, "session:any:0:count", count_file)
        counts = {}
        for line in open(count_file):
            op, n = line.split()
            counts[op] = max(counts.get(op, 0), int(n))
        print(f"io faults: a 2-s session makes {counts} calls on its files (seed {seed})", flush=True)
        for op in args.ops.split(","):
            for what in [w for w in args.what.split(",") if op == "write" or w == "eio-once"]:
                first = 1 + (random.Random(seed).randrange(args.stride) if args.stride > 1 else 0)
                tried = fired = kept = 0
                for n in range(first, counts.get(op, 0) + 1, args.stride):
                    tried += 1
                    code, out, folder = session(work, f"session:{op}:{n}:{what}")
                    verdict = judge(code, out, folder)
                    if verdict is None:
                        continue
                    fired += 1
                    if verdict == "":
                        kept += 1
                    else:
                        broken += 1
                        print(f"  {op} #{n} {what}: {verdict}", flush=True)
                print(f"io faults: {op} {what}: {tried} tried, {fired} fired, {kept} kept the rule (exit 1, the file "
                      f"and the error named, recover and verify clean)", flush=True)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    print(f"io faults: {broken} runs broke the rule; {time.time() - started:.0f} s")
    return 1 if broken else 0


if __name__ == "__main__":
    sys.exit(main())
