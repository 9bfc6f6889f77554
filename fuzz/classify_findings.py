#!/usr/bin/env python3
"""Says where each finding of a fuzz run lies: runs the target on every saved input (crash-*,
timeout-*, oom-*, leak-*) and reports the innermost stack frame inside HDF5 (libhdf5), the LZ4
plugin, or this project's code (a source path under core/, kernels/, io/, engine/, fuzz/); the
frames of the sanitizers, libFuzzer and the C and C++ libraries are passed over.

Usage: fuzz/classify_findings.py FUZZER ARTIFACT_DIR
"""
import collections
import os
import re
import subprocess
import sys

FRAME = re.compile(r"^\s*#\d+ 0x[0-9a-f]+ (?:in (.*?) )?\(?([^ ()]+)?")


def where(text):
    kind = "?"
    for pattern, name in [(r"AddressSanitizer: ([\w-]+)", None), (r"libFuzzer: (timeout)", None),
                          (r"(out-of-memory) \((malloc|used)", None),
                          (r"runtime error: (.*)", None), (r"^finding: (.*)", None)]:
        m = re.search(pattern, text, re.M)
        if m:
            kind = m.group(1)
            break
    for line in text.splitlines():
        m = FRAME.match(line)
        if not m:  # frames of the sanitizers, libFuzzer and the libc match nothing below
            continue
        if "libhdf5" in line:
            fn = m.group(1) or "?"
            return kind, "HDF5 (libhdf5" + (", " + fn if fn != "?" else "") + ")"
        if "lz4" in line.lower() and ".so" in line:
            return kind, "LZ4 plugin"
        src = re.search(r"/(core|kernels|io|engine|fuzz)/[\w./]+:\d+", line)
        if src:
            return kind, "project: " + src.group(0).lstrip("/")
    if kind.startswith("finding"):
        return kind, "project (the target's own check)"
    return kind, "unknown"


def main():
    fuzzer, folder = sys.argv[1], sys.argv[2]
    env = dict(os.environ, ASAN_OPTIONS="detect_leaks=0:fast_unwind_on_malloc=0")
    counts = collections.Counter()
    for name in sorted(os.listdir(folder)):
        path = os.path.join(folder, name)
        run = subprocess.run([fuzzer, "-timeout=2", "-rss_limit_mb=2048", "-malloc_limit_mb=512",
                              path], capture_output=True, text=True, env=env, timeout=120)
        kind, place = where(run.stderr)
        if run.returncode == 0:
            kind, place = "no longer reproduces", "-"
        counts[(name.split("-")[0], kind, place)] += 1
        print(f"{name}: {kind}: {place}", flush=True)
    print("\nsummary:")
    for (prefix, kind, place), n in sorted(counts.items()):
        print(f"{n:4d}  {prefix:8s} {kind:32s} {place}")


if __name__ == "__main__":
    main()
