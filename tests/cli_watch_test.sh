#!/usr/bin/env bash
# End-to-end test of `tactres watch`'s exit codes and messages on bad input,
# and of Ctrl-C: a long sequence interrupted ends with the summary, exit 0,
# and a complete CSV (docs/LIVE.md).
# Usage: cli_watch_test.sh PATH/TO/tactres
set -u
tactres="$1"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
failures=0
fail() { echo "FAIL: $*" >&2; failures=$((failures + 1)); }

"$tactres" generate --out "$work/target" >/dev/null || { echo "FAIL: generate"; exit 1; }
layout="$work/target/layout.json"

# expect CODE NAME WORD ARGS...: exit CODE and WORD in the message.
expect() {
  local code="$1" name="$2" word="$3"
  shift 3
  "$tactres" watch "$@" >"$work/out" 2>"$work/err"
  local rc=$?
  [ "$rc" -eq "$code" ] || fail "$name: exit $rc, expected $code: $(cat "$work/err")"
  grep -qi -- "$word" "$work/err" "$work/out" || fail "$name: no '$word' in: $(cat "$work/err")"
}

expect 3 "missing source" "no such file or folder" "$work/nothing" --layout "$layout"
mkdir -p "$work/empty"
expect 3 "folder without images" "holds no image" "$work/empty" --layout "$layout"
expect 3 "no target given" "--layout" "$work/target" 
expect 3 "malformed layout" "not valid JSON" "$work/target" --layout "$work/target/target.svg"
expect 3 "bad refit" "--refit-every" "$work/target" --layout "$layout" --refit-every 0
expect 3 "bad size" "--size" "/dev/video99" --layout "$layout" --size big
DISPLAY= WAYLAND_DISPLAY= expect 3 "window without display" "display" "$work/target" --layout "$layout" --window
cp "$layout" "$work/layout_copy.json"
expect 3 "CSV over the layout" "is also an input" "$work/target" --layout "$work/layout_copy.json" \
  --csv "$work/layout_copy.json"
cmp -s "$layout" "$work/layout_copy.json" || fail "CSV over the layout: the layout was changed"
expect 3 "focus group not on the target" "the target has groups 0..4, not 9" "$work/target" --layout "$layout" \
  --focus-element 9 1
# One image is one frame, decoded as measure decodes it (not as a video).
"$tactres" watch "$work/target/height.tif" --layout "$layout" >"$work/out" 2>"$work/err"
grep -q "watching image .*height.tif (1 image(s))" "$work/err" || fail "one image: not read as one frame: $(cat "$work/err")"
grep -q "^1 frame(s), 0 measured" "$work/out" || fail "one image: the summary: $(cat "$work/out")"
# Without a CSV, the summary still says why no frame was measured.
grep -q "no frame could be measured: no target found" "$work/err" || fail "one image: the reason is not given: $(cat "$work/err")"

# Frames without the target: every row says why, exit 2, the summary says so.
mkdir -p "$work/blank"
cp "$work/target/height.tif" "$work/blank/a.tif"   # an image without the target's discs
printf 'not an image' >"$work/blank/b.png"
"$tactres" watch "$work/blank" --layout "$layout" --csv "$work/blank.csv" >"$work/out" 2>"$work/err"
rc=$?
[ "$rc" -eq 2 ] || [ "$rc" -eq 0 ] || fail "blank frames: exit $rc"
[ "$(wc -l <"$work/blank.csv")" -eq 3 ] || fail "blank frames: CSV should hold a header and 2 rows: $(cat "$work/blank.csv")"
grep -q "b.png,unusable" "$work/blank.csv" || fail "the bad file's row is not unusable: $(cat "$work/blank.csv")"
grep -qi "nan" "$work/blank.csv" && fail "NaN in the CSV"

# Ctrl-C: a long sequence (the same raster repeated) ends with the summary.
mkdir -p "$work/long"
for i in $(seq -w 1 400); do ln -s "$work/target/target.png" "$work/long/f$i.png"; done
"$tactres" watch "$work/long" --layout "$layout" --csv "$work/long.csv" >"$work/out" 2>"$work/err" &
pid=$!
sleep 2
kill -INT "$pid"
wait "$pid"
rc=$?
[ "$rc" -eq 0 ] || [ "$rc" -eq 2 ] || fail "Ctrl-C: exit $rc, expected 0 or 2"
grep -q "stopped by the user" "$work/out" || fail "Ctrl-C: no summary: $(cat "$work/out") $(cat "$work/err")"
rows=$(($(wc -l <"$work/long.csv") - 1))
grep -q "^$rows frame(s)" "$work/out" || fail "Ctrl-C: the summary's $(head -c 20 "$work/out") is not the CSV's $rows rows"
[ "$rows" -lt 400 ] || fail "Ctrl-C did not stop the run"

[ "$failures" -eq 0 ] && echo "cli_watch: all checks passed"
exit $((failures > 0))
