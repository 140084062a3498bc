#!/usr/bin/env bash
# Fuzzes the readers and the FMU's C API until BUDGET_SECONDS (default 600) are spent,
# split evenly over the targets:
#
#   readers:timeseries  readers:frf_csv  readers:uff  readers:twin
#       identify/tests/io/fuzz_readers.rs (arbitrary bytes + mutated valid files), rerun
#       with fresh random seeds and PROPTEST_CASES doubling from round to round
#   fmu:c_api
#       fmu/tests/ffi.rs c_api_survives_misuse_and_random_call_sequences and its FMI 3.0
#       twin fmi3_c_api_survives_... with a fresh MTWIN_FUZZ_SEED per round and
#       MTWIN_FUZZ_CALLS doubling
#
# Appends one line per target to fuzz/LOG.md (date, target, seconds, inputs tried,
# failures). The output of a failing round is kept in fuzz/failures/; proptest also
# records the failing seed in identify/tests/io/fuzz_readers.proptest-regressions.
#
# Usage: scripts/fuzz.sh [BUDGET_SECONDS]
set -euo pipefail

budget=${1:-600}
if ! [[ $budget =~ ^[0-9]+$ ]] || ((budget < 5)); then
    echo "usage: $0 [BUDGET_SECONDS >= 5]" >&2
    exit 2
fi
cd "$(dirname "$0")/.."
mkdir -p fuzz/failures
log=fuzz/LOG.md
if [[ ! -f $log ]]; then
    cat >"$log" <<'EOF'
# Fuzz log

Appended by `scripts/fuzz.sh`: one line per target and run. "inputs" counts generated
inputs of the rounds that passed (proptest cases over both properties of a reader
target; random C-API calls for the FMU). "failures" counts failing rounds; their output
is in `fuzz/failures/` (not committed).

| date (UTC) | target | seconds | rounds | inputs tried | failures |
|---|---|---|---|---|---|
EOF
fi

echo "building the fuzz targets ..." >&2
cargo test -q -p identify --test identify --no-run 2>/dev/null
cargo test -q -p mtwin-fmu --test ffi --no-run 2>/dev/null

targets=(readers:timeseries readers:frf_csv readers:uff readers:twin fmu:c_api)
share=$((budget / ${#targets[@]}))
any_failed=0

seed() { od -An -N8 -tx8 /dev/urandom | tr -d ' \n'; }

for target in "${targets[@]}"; do
    case $target in
    readers:timeseries) filter=io::fuzz_readers::timeseries_ ;;
    readers:frf_csv) filter=io::fuzz_readers::frf_csv_ ;;
    readers:uff) filter=io::fuzz_readers::uff_ ;;
    readers:twin) filter=io::fuzz_readers::twin_ ;;
    fmu:c_api) filter=c_api_survives ;;
    esac
    if [[ $target == fmu:* ]]; then n=200000; else n=2000; fi
    start=$(date +%s)
    inputs=0 failures=0 rounds=0
    while :; do
        now=$(date +%s)
        left=$((start + share - now))
        ((left > 0)) || break
        out=$(mktemp)
        t0=$(date +%s)
        rc=0
        if [[ $target == fmu:* ]]; then
            s=$(seed)
            MTWIN_FUZZ_CALLS=$n MTWIN_FUZZ_SEED=0x$s timeout $((left + 30)) \
                cargo test -q -p mtwin-fmu --test ffi "$filter" -- --nocapture \
                >"$out" 2>&1 || rc=$?
            per_round=$n
        else
            PROPTEST_CASES=$n timeout $((left + 30)) \
                cargo test -q -p identify --test identify "$filter" >"$out" 2>&1 || rc=$?
            per_round=$((2 * n)) # an arbitrary-bytes and a mutation property
        fi
        took=$(($(date +%s) - t0))
        rounds=$((rounds + 1))
        if ((rc == 124)); then
            echo "$target: round of $n stopped at the budget" >&2
        elif ((rc != 0)); then
            # a failing round stops early: its inputs are not counted, and the next
            # round is not larger
            failures=$((failures + 1))
            any_failed=1
            keep=fuzz/failures/${target/:/-}-$(date -u +%Y%m%dT%H%M%S).txt
            cp "$out" "$keep"
            echo "$target: FAILURE (round of $n), output in $keep" >&2
        else
            inputs=$((inputs + per_round))
            # double the round while a doubled round still fits in what is left
            left=$((start + share - $(date +%s)))
            if ((2 * took + 1 < left)); then n=$((n * 2)); fi
        fi
        rm -f "$out"
    done
    secs=$(($(date +%s) - start))
    echo "$target: ${secs} s, $rounds rounds, $inputs inputs, $failures failures" >&2
    echo "| $(date -u '+%Y-%m-%d %H:%M') | $target | $secs | $rounds | $inputs | $failures |" >>"$log"
done
exit $any_failed
