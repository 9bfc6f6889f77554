#!/usr/bin/env bash
# A long fuzz run on one core, niced, that goes on after a finding: libFuzzer's fork mode with
# one job at a time (-fork=1; the machine is shared: never more jobs or workers) runs the target
# in a child, saves each crash, timeout or out-of-memory input to WORKDIR/artifacts/ and goes on
# with a new child on the grown corpus. Prints the inputs run, wall and CPU seconds, and the
# findings by kind; fuzz/classify_findings.sh says where each one is.
# Usage: fuzz/long_run.sh FUZZER SECONDS WORKDIR [SEED_DIR] [extra libFuzzer flags...]
set -uo pipefail
fuzzer=$1 seconds=$2 work=$3
shift 3
seeds=()
if [[ $# -gt 0 && -d $1 ]]; then seeds=("$1"); shift; fi
mkdir -p "$work/corpus" "$work/artifacts"
# HDF5 leaks on its own error paths (fuzz/lsan.supp), on nearly every damaged file: leak
# detection is off (libFuzzer's and ASan's at exit); -rss_limit_mb still stops a growth. A small
# quarantine keeps ASan's use-after-free check for recent frees without touching fresh pages on
# every file (about 2x faster: HDF5 allocates a metadata cache per open file). Stacks are
# symbolized later, by fuzz/classify_findings.py (llvm-symbolizer on every timeout cost seconds).
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=0:quarantine_size_mb=4:symbolize=0}
log="$work/fuzz-$(date +%Y%m%d-%H%M%S).log"
TIMEFORMAT='%R %U %S'
# A timeout is 2 s: a valid library takes about 5 ms; HDF5 spins on some damaged global heaps.
times=$( { time nice -n 10 "$fuzzer" -fork=1 -ignore_crashes=1 -ignore_ooms=1 \
  -ignore_timeouts=1 -detect_leaks=0 -timeout=2 -rss_limit_mb=2048 -malloc_limit_mb=512 \
  -max_total_time="$seconds" -artifact_prefix="$work/artifacts/" "$@" "$work/corpus" \
  "${seeds[@]}" >"$log" 2>&1; } 2>&1 )
read -r wall user system <<<"$times"
inputs=$(sed -n 's/^#\([0-9]*\): cov.*/\1/p' "$log" | tail -1)
cpu=$(awk -v u="$user" -v s="$system" 'BEGIN {print u + s}')
echo "log: $log"
echo "inputs: ${inputs:-0}  wall: ${wall} s  cpu: ${cpu} s" \
  "exec/s: $(awk -v n="${inputs:-0}" -v t="$wall" 'BEGIN {printf "%.0f", n / t}') wall," \
  "$(awk -v n="${inputs:-0}" -v t="$cpu" 'BEGIN {printf "%.0f", n / t}') per CPU second"
grep -o 'oom/timeout/crash: [0-9/]*' "$log" | tail -1
ls "$work/artifacts" | sed 's/-.*//' | sort | uniq -c
