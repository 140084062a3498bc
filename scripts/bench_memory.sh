#!/usr/bin/env bash
# Peak memory (RSS) and wall time of `mtwin frf` on long continuous-excitation records
# (default 1 min and 10 min at 25.6 kHz, columns t,fx,fy,ax,ay), streamed (what
# `mtwin frf` does for a single file of 8 MiB or more) and read into memory
# (`--in-memory`). Prints a markdown table; `--write` also stores it in bench/memory.md.
#
#   scripts/bench_memory.sh [--write]
#   DURATIONS="60 600 1200" BENCH_DIR=/tmp/mem scripts/bench_memory.sh
#
# The records are written by `examples/long_record.rs` (row by row, never held in
# memory) into BENCH_DIR (default target/bench-memory, ~70 MB per minute) and reused on
# the next run. Measured with GNU time (`/usr/bin/time -v`) when present, else with
# Python's resource module (peak RSS of the child).
set -euo pipefail
cd "$(dirname "$0")/.."
DIR=${BENCH_DIR:-target/bench-memory}
DURATIONS=${DURATIONS:-"60 600"}
FS=${FS:-25600}
WRITE=0
[[ "${1:-}" == "--write" ]] && WRITE=1

cargo build --release --quiet --bin mtwin --example long_record
MTWIN=target/release/mtwin
GEN=target/release/examples/long_record
mkdir -p "$DIR"

# measure CMD...: prints "PEAK_RSS_KB SECONDS"; fails when CMD fails
measure() {
    if /usr/bin/time -v true >/dev/null 2>&1; then
        local log
        log=$(mktemp)
        if ! /usr/bin/time -v "$@" >/dev/null 2>"$log"; then
            cat "$log" >&2
            rm -f "$log"
            return 1
        fi
        awk -F': ' '
            /Maximum resident set size/ { rss = $2 }
            /Elapsed \(wall clock\)/ {
                n = split($2, p, ":"); s = 0
                for (i = 1; i <= n; i++) s = s * 60 + p[i]
                secs = s
            }
            END { printf "%d %.2f\n", rss, secs }' "$log"
        rm -f "$log"
    else
        python3 - "$@" <<'PY'
import resource, subprocess, sys, time
t = time.time()
subprocess.run(sys.argv[1:], check=True, stdout=subprocess.DEVNULL)
dt = time.time() - t
print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss, f"{dt:.2f}")
PY
    fi
}

table="| reading | record | rows | file MB | peak RSS MB | seconds |
|---|---|---:|---:|---:|---:|"
for secs in $DURATIONS; do
    csv="$DIR/record_${secs}s.csv"
    if [[ ! -s "$csv" ]]; then
        echo "writing $csv ..." >&2
        "$GEN" "$secs" "$csv" --fs "$FS" >&2
    fi
    rows=$(( $(grep -vc '^#' "$csv") - 1 ))
    mb=$(awk -v b="$(stat -c %s "$csv")" 'BEGIN { printf "%.0f", b / 1048576 }')
    for mode in streamed in_memory; do
        flag=()
        [[ $mode == in_memory ]] && flag=(--in-memory)
        out="$DIR/frf_${secs}s_${mode}.csv"
        read -r rss sec < <(measure "$MTWIN" frf "$csv" --out "$out" "${flag[@]}")
        echo "$mode ${secs}s: ${rss} kB, ${sec} s" >&2
        rssmb=$(awk -v k="$rss" 'BEGIN { printf "%.1f", k / 1024 }')
        table+="
| $mode | $((secs / 60)) min at $FS Hz | $rows | $mb | $rssmb | $sec |"
    done
    if ! cmp -s "$DIR/frf_${secs}s_streamed.csv" "$DIR/frf_${secs}s_in_memory.csv"; then
        echo "warning: streamed and in-memory FRF files differ for ${secs}s" >&2
    fi
done

echo "$table"
if [[ $WRITE == 1 ]]; then
    {
        echo "# mtwin frf: peak memory on long records"
        echo
        echo "\`scripts/bench_memory.sh --write\` on $(nproc) cores, $(date -u +%Y-%m-%d)," \
            "commit $(git rev-parse --short HEAD). Continuous excitation, columns" \
            "t,fx,fy,ax,ay (two force directions: MIMO H1), automatic nfft (65536)."
        echo "Peak RSS and wall time from GNU time; \"streamed\" is what \`mtwin frf\` does" \
            "for a single file of 8 MiB or more, \"in_memory\" is \`--in-memory\`."
        echo "Both write the same FRF file (compared byte for byte by the script)."
        echo
        echo "$table"
    } >bench/memory.md
    echo "wrote bench/memory.md" >&2
fi
