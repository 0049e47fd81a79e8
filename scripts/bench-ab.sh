#!/usr/bin/env bash
# Chart-mode speed of this checkout against another revision, in rounds
# that alternate the two builds: this machine's speed drifts by 10-30 %
# within minutes (docs/BENCH.md, session 25), so two benchmarks run one
# after the other compare the machine's moods, not the code.
# Usage: bash scripts/bench-ab.sh REV [ROUNDS [REPS [FILE...]]]
#   REV     the revision to compare against (built in build/bench-ab/REV)
#   ROUNDS  alternating rounds (default 3), REPS the benchmark's repetitions
#           each (default 9), FILE... extra 8-bit frames (as for
#           tactres_chart_benchmark)
# Prints each round's lines of both builds; nothing is written outside build/.
set -euo pipefail
cd "$(dirname "$0")/.."
[ $# -ge 1 ] || { echo "usage: bash scripts/bench-ab.sh REV [ROUNDS [REPS [FILE...]]]" >&2; exit 3; }
rev=$(git rev-parse --short "$1^{commit}") || { echo "bench-ab: '$1' is not a revision of this repository" >&2; exit 3; }
rounds=${2:-3}
reps=${3:-9}
shift $(( $# < 3 ? $# : 3 ))
bash scripts/build.sh > build.log 2>&1 || { tail -50 build.log; exit 1; }
# The other revision's benchmark, built once in a scratch work tree and kept
# as build/bench-ab/REV/tactres_chart_benchmark.
other=build/bench-ab/$rev
bin_other=$other/tactres_chart_benchmark
if [ ! -x "$bin_other" ]; then
  tree=build/bench-ab/tree-$rev
  rm -rf "$tree" "$other"
  mkdir -p "$other"
  git worktree add --detach -q "$tree" "$rev"
  trap 'git worktree remove --force "$tree" > /dev/null 2>&1 || true' EXIT
  cmake -S "$tree" -B "$tree/build" -G Ninja -DCMAKE_BUILD_TYPE=Release > "$other/configure.log" 2>&1 ||
    { cat "$other/configure.log"; exit 1; }
  cmake --build "$tree/build" --parallel "$(nproc)" --target tactres_chart_benchmark > "$other/build.log" 2>&1 ||
    { tail -50 "$other/build.log"; exit 1; }
  cp "$tree/build/tests/tactres_chart_benchmark" "$bin_other"
fi
for ((r = 1; r <= rounds; ++r)); do
  for side in "$rev" this; do
    bin=$([ "$side" = this ] && echo build/tests/tactres_chart_benchmark || echo "$bin_other")
    echo "== round $r, $side"
    OMP_THREAD_LIMIT=1 "$bin" "$reps" "$@" | grep -E "^  (decode|stages)" | sed 's/^/  /'
  done
done
