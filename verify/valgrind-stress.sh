#!/usr/bin/env bash
# Valgrind memcheck over the stress suite (`tests/stress.rs`) and the leak checks (`tests/leaks.rs`),
# release builds: invalid reads and writes, double or mismatched frees, uses after free, and leaks
# (definite, indirect and possible ones are all errors). Memcheck runs one thread at a time, which
# is fine for these; it is 30-50 times slower, so the stress suite runs at a reduced size (about
# 2 minutes at 0.1 on a shared 2-core machine).
#
#   verify/valgrind-stress.sh                       # stress at WFIC_STRESS_SCALE=0.1, leaks 20 rounds
#   WFIC_STRESS_SCALE=1 verify/valgrind-stress.sh   # the stress suite at full size (an hour or more)
#
# Logs: target/valgrind-build/valgrind/{stress,leaks}.log (under CARGO_TARGET_DIR if set). Exit status 1 if
# memcheck reports any error in either run.
set -euo pipefail
cd "$(dirname "$0")/.."
command -v valgrind >/dev/null || { echo "valgrind not found (Debian: apt-get install valgrind)"; exit 2; }

export WFIC_STRESS_SCALE="${WFIC_STRESS_SCALE:-0.1}"
export WFIC_LEAKS_ROUNDS="${WFIC_LEAKS_ROUNDS:-20}"
# Memcheck runs one thread at a time and switches only every 100 000 blocks or at a system call, so
# two inserts almost never interleave inside the window between a null read and the
# compare-and-swap on it, and the losers' frees (`graft`, `install`) would go unchecked. The leak
# checks' allocator yields after each allocation of a WF round (WF allocates inside that window),
# so under memcheck too both kinds of race are lost, hundreds of times; the checks require it.
export WFIC_LEAKS_YIELD=1
# Memcheck (3.19, Debian 12) stops at AVX-512 instructions ("unrecognised instruction"), which the
# repository's `target-cpu=native` emits on a CPU that has them (the AMD EPYC CI machines do): the
# binaries under memcheck are built for x86-64-v3 (AVX2, FMA) instead, in a target dir of their own.
export RUSTFLAGS="${WFIC_VALGRIND_RUSTFLAGS:--C target-cpu=x86-64-v3}"
export CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-target/valgrind-build}"

target="${CARGO_TARGET_DIR:-target}"
logs="$target/valgrind"
mkdir -p "$logs"

# The path of the test binary `name`, built in release mode.
binary() {
    cargo test --release --test "$1" --no-run --message-format=json \
        | grep '"reason":"compiler-artifact"' \
        | grep "\"name\":\"$1\"" \
        | grep -o '"executable":"[^"]*"' \
        | tail -n 1 | cut -d '"' -f 4
}

memcheck() {
    local name="$1"; shift
    local exe; exe="$(binary "$name")"
    [ -x "$exe" ] || { echo "no test binary for $name"; exit 2; }
    echo "== memcheck: $name ($exe $*)"
    local start=$SECONDS status=0
    valgrind --tool=memcheck --error-exitcode=1 \
        --leak-check=full --show-leak-kinds=definite,indirect,possible \
        --errors-for-leak-kinds=definite,indirect,possible \
        --suppressions=verify/valgrind.supp \
        "$exe" "$@" >"$logs/$name.log" 2>&1 || status=$?
    grep -E "test result|leaks: .* ok|rounds, allocations|ERROR SUMMARY|definitely lost|indirectly lost|possibly lost:|suppressed:" \
        "$logs/$name.log" | sed 's/^==[0-9]*== *//'
    echo "   wall time $((SECONDS - start)) s, exit status $status, log $logs/$name.log"
    return "$status"
}

failed=0
# --test-threads=1: libtest runs the tests one after another (memcheck serialises threads anyway).
memcheck stress --test-threads=1 || failed=1
memcheck leaks || failed=1
# Removal racing inserts and lookups: 10^6 operations a scheme, at 2 and at 8 workers.
WFIC_REMOVAL_STRESS_OPS="${WFIC_REMOVAL_STRESS_OPS:-1000000}" memcheck removal_stress --test-threads=1 || failed=1
exit "$failed"
