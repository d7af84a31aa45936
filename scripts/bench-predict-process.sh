#!/usr/bin/env bash
# Whole-process cost of `tapeshape predict` (issue 13): wall time and peak
# memory of one process with the quick set's four readings and the mesh
# written, median of N runs (default 10), as /usr/bin/time -v reports them.
#
#   scripts/bench-predict-process.sh [path/to/tapeshape] [N]
#
# The data directory is a fresh temporary one: the first run decodes the
# embedded model and writes its cache (reported apart), the N timed runs
# read the cache, as every start after the first on a machine does.
set -euo pipefail
bin=${1:-target/release/tapeshape}
n=${2:-10}
data=$(mktemp -d)
out=$(mktemp -d)
trap 'rm -rf "$data" "$out"' EXIT
args=(predict --measure stature=176.5cm --measure chest=98cm --measure waist=84cm
      --measure hip=100cm -o "$out/body.glb")
run() {
    /usr/bin/time -v env TAPESHAPE_DATA_DIR="$data" "$bin" "${args[@]}" \
        >/dev/null 2>"$out/time.txt"
    wall=$(grep 'Elapsed (wall clock)' "$out/time.txt" | awk '{print $NF}')
    rss=$(grep 'Maximum resident set size' "$out/time.txt" | awk '{print $NF}')
    # m:ss.cc -> seconds
    secs=$(echo "$wall" | awk -F: '{ if (NF == 3) print $1*3600+$2*60+$3; else print $1*60+$2 }')
    echo "$secs $rss"
}
first=$(run)
echo "first run (no cache; decodes and writes it): wall $(echo "$first" | cut -d' ' -f1) s, peak $(( $(echo "$first" | cut -d' ' -f2) / 1024 )) MiB"
for _ in $(seq "$n"); do run; done > "$out/runs.txt"
median() { sort -n | awk '{a[NR]=$1} END {if (NR % 2) print a[(NR+1)/2]; else print (a[NR/2]+a[NR/2+1])/2}'; }
wall=$(cut -d' ' -f1 "$out/runs.txt" | median)
rss=$(cut -d' ' -f2 "$out/runs.txt" | median)
echo "cached runs ($n): median wall ${wall} s, median peak $(( ${rss%.*} / 1024 )) MiB"
echo "walls: $(cut -d' ' -f1 "$out/runs.txt" | tr '\n' ' ')"
