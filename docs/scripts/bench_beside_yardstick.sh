#!/usr/bin/env bash
# One entry of the voxel_coloring bench, run after run, each run right after the issue's
# yardstick loop (host_yardstick.c), so that every time comes with how fast the host was just
# before it: this host's slow hours cost the kernel 20-70% (docs/results.md, "The bench over
# the sessions"), and a median means something only beside the yardstick's.
#
#   docs/scripts/bench_beside_yardstick.sh ENTRY [RUNS]    # e.g. 128 7, or 256 5
#
# Builds the yardstick (gcc) and the bench (release) first, then prints one line a run and
# the medians. Run it with nothing else running. CARGO_TARGET_DIR is honoured.
set -euo pipefail

entry=${1:?usage: $0 ENTRY [RUNS] (ENTRY: 128, 256, 128_column_test, ...)}
runs=${2:-7}
case $runs in
'' | *[!0-9]* | 0) echo "RUNS must be a whole number of runs, at least 1: $runs" >&2 && exit 2 ;;
esac

root=$(cd "$(dirname "$0")/../.." && pwd)
target=${CARGO_TARGET_DIR:-$root/target}
mkdir -p "$target"
yardstick=$target/host_yardstick
gcc -O2 -pthread -o "$yardstick" "$root/docs/scripts/host_yardstick.c" -lm

# The bench's executable, as cargo reports it (cargo's own messages, a compile error among
# them, go to the terminal).
bench=$(cd "$root" && cargo bench -p aibr-benches --bench voxel_coloring --no-run \
    --message-format=json |
    grep -o '"executable":"[^"]*voxel_coloring[^"]*"' | tail -1 | cut -d'"' -f4 || true)
if [ -z "$bench" ] || [ ! -x "$bench" ]; then
    echo "could not build the voxel_coloring bench (cargo bench -p aibr-benches --no-run)" >&2
    exit 1
fi

# The middle of criterion's three time estimates, in milliseconds.
bench_ms() {
    "$bench" --bench "^voxel_coloring/$entry\$" 2>&1 |
        grep -A1 "^voxel_coloring/$entry " | grep -o 'time: *\[[^]]*\]' |
        awk '{ v = $4; u = $5; if (u == "s") v *= 1000; else if (u == "µs") v /= 1000; print v }'
}

median() { sort -g | awk '{ a[NR] = $1 } END { if (NR == 0) exit 1; print (NR % 2 ? a[(NR + 1) / 2] : (a[NR / 2] + a[NR / 2 + 1]) / 2) }'; }

ys=()
ts=()
for run in $(seq 1 "$runs"); do
    y=$("$yardstick" | tail -1 | sed -E 's/.* ([0-9.]+) M voxel-projections.*/\1/')
    t=$(bench_ms || true)
    if [ -z "$t" ]; then
        echo "run $run: no time for voxel_coloring/$entry (is it a bench entry?)" >&2
        exit 1
    fi
    ys+=("$y")
    ts+=("$t")
    echo "run $run: yardstick $y M voxel-projections/s, voxel_coloring/$entry $t ms"
done
echo "medians of $runs: voxel_coloring/$entry $(printf '%s\n' "${ts[@]}" | median) ms," \
    "the yardstick $(printf '%s\n' "${ys[@]}" | median) M voxel-projections/s"
