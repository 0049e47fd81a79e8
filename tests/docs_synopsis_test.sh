#!/usr/bin/env bash
# The docs show what `tactres measure` prints: every `$ tactres measure ...`
# in README.md and docs/CHART.md that is followed by its output is run, and
# the first line it prints must be the one the docs show (a golden test of
# the docs, so that they never drift from the build). The inputs the
# commands name are made first, as the docs make them; commands on the real
# captures run only when ../shared/realdata is there, and say so otherwise.
# Usage: docs_synopsis_test.sh PATH/TO/tactres REPO_ROOT
set -u
tactres="$1"
repo="$2"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
failures=0
fail() { echo "FAIL: $*" >&2; failures=$((failures + 1)); }

# The working folder stands where the repository would: examples/ beside,
# ../shared above.
mkdir -p "$work/repo"
ln -s "$repo/examples" "$work/repo/examples"
[ -d "$repo/../shared/realdata" ] && ln -s "$(cd "$repo/../shared" && pwd)" "$work/shared"
cd "$work/repo" || exit 1
quiet() { "$@" >/dev/null 2>"$work/stderr" || fail "$* exited $?: $(cat "$work/stderr")"; }
quiet "$tactres" generate --out out/target
quiet "$tactres" simulate examples/scenes/cmos.json --layout out/target/layout.json -o out/captures/cmos.png
cp out/captures/cmos.png cmos.png
quiet "$tactres" generate --style mil-std-150a --first-group 0 --last-group 5 --px-per-mm 60 --out target
quiet "$tactres" simulate examples/charts/usaf1951.json --layout target/layout.json -o chart.png

# Each documented command (its "\" continuation lines joined) with the line
# it prints, tab-separated.
extract() {
  awk '
    /^ *\$ tactres measure / { cmd = $0; sub(/^ *\$ /, "", cmd); joining = (cmd ~ /\\$/); want = 1; next }
    joining { line = $0; sub(/^ */, "", line); sub(/\\$/, "", cmd); cmd = cmd line; joining = (line ~ /\\$/); next }
    want && /^ *(\$|```)/ { want = 0; next }
    want { out = $0; sub(/^ */, "", out); print cmd "\t" out; want = 0 }
  ' "$1"
}

checked=0
skipped=0
for doc in README.md docs/CHART.md; do
  while IFS=$'\t' read -r cmd expected; do
    if [[ "$cmd" == *../shared/* ]] && [ ! -e "$work/shared" ]; then
      skipped=$((skipped + 1))
      continue
    fi
    args="${cmd#tactres }"
    # The docs' commands are plain words (no quoting or globbing).
    read -r -a argv <<<"$args"
    "$tactres" "${argv[@]}" >"$work/stdout" 2>&1
    got="$(head -n 1 "$work/stdout")"
    checked=$((checked + 1))
    [ "$got" == "$expected" ] || fail "$doc: \`$cmd\` prints
  $got
but the docs show
  $expected"
  done < <(extract "$repo/$doc")
done
echo "docs synopsis: $checked command(s) checked$([ "$skipped" -gt 0 ] && echo ", $skipped on the real captures skipped (../shared/realdata absent)")"
[ "$checked" -ge 4 ] || fail "only $checked documented measure commands found; the extraction is broken"
[ "$failures" -eq 0 ] || { echo "$failures failure(s)" >&2; exit 1; }
