#!/usr/bin/env bash
# End-to-end test of `tactres generate`: a good run writes the six outputs;
# every bad input exits 3 with a message on stderr and leaves no file behind.
# Usage: cli_generate_test.sh PATH/TO/tactres
set -u
tactres="$1"
work="$(mktemp -d)"
trap 'chmod -R u+w "$work" 2>/dev/null; rm -rf "$work"' EXIT
failures=0
fail() { echo "FAIL: $*" >&2; failures=$((failures + 1)); }

outputs="layout.json target.svg target.png target.tif height.tif relief.stl"

# --- A good run -------------------------------------------------------------
"$tactres" generate --out "$work/good" >"$work/stdout" 2>"$work/stderr"
rc=$?
[ "$rc" -eq 0 ] || fail "default generate exited $rc: $(cat "$work/stderr")"
for f in $outputs; do
  [ -s "$work/good/$f" ] || fail "default generate did not write a non-empty $f"
done
n=$(ls -A "$work/good" | wc -l)
[ "$n" -eq 6 ] || fail "expected exactly 6 files in the output folder, found $n: $(ls -A "$work/good")"
grep -q "800 x 800 px" "$work/stdout" || fail "summary does not give the raster size: $(cat "$work/stdout")"
grep -q "wrote 6 files to" "$work/stdout" || fail "summary does not count the six files written: $(cat "$work/stdout")"
grep -q "groups 0..4" "$work/stdout" || fail "summary does not give the groups"
head -c 5 "$work/good/relief.stl" | grep -q solid && fail "relief.stl looks like ASCII STL"
grep -q '"schema": *"tactres.target/1"' "$work/good/layout.json" || fail "layout.json lacks its schema"

# Options reach the outputs: a 25 x 20 field at 10 px/mm gives 250 x 200 px.
"$tactres" generate --out "$work/custom" --field-mm 25x20 --px-per-mm 10 --relief-um 250 \
  --polarity light_bars_on_dark --first-group 1 --last-group 3 >"$work/stdout" 2>"$work/stderr" ||
  fail "custom generate failed: $(cat "$work/stderr")"
grep -q "250 x 200 px" "$work/stdout" || fail "custom raster size wrong: $(cat "$work/stdout")"
grep -q 'width="25mm" height="20mm"' "$work/custom/target.svg" || fail "custom SVG size wrong"
grep -q '"relief_height_mm": *0.25' "$work/custom/layout.json" || fail "relief height not in layout.json"

# --- Bad input: exit 3, a message, nothing written ---------------------------
# expect_refusal NAME OUTDIR ARGS...: OUTDIR must afterwards be absent or empty
# (apart from what the case itself put there, listed in $keep).
keep=""
expect_refusal() {
  local name="$1" out="$2"
  shift 2
  "$tactres" generate --out "$out" "$@" >"$work/stdout" 2>"$work/stderr"
  local rc=$?
  [ "$rc" -eq 3 ] || fail "$name: exit code $rc, expected 3"
  [ -s "$work/stderr" ] || fail "$name: no message on stderr"
  if [ -d "$out" ]; then
    local left
    left="$(ls -A "$out" | grep -vxF -e "${keep:-/}" || true)"
    [ -z "$left" ] || fail "$name: left files behind: $left"
  fi
  echo "ok: $name -> $(head -n 1 "$work/stderr")"
}

expect_refusal "inverted group range" "$work/b1" --first-group 3 --last-group 1
expect_refusal "zero px/mm" "$work/b2" --px-per-mm 0
expect_refusal "negative px/mm" "$work/b3" --px-per-mm=-5
expect_refusal "px/mm above 2000" "$work/b4" --px-per-mm 2500
expect_refusal "field too small for the groups" "$work/b5" --field-mm 8 --last-group 5
grep -q "fit" "$work/stderr" || fail "field-too-small message does not say what fits"
expect_refusal "malformed field" "$work/b6" --field-mm 20by20
expect_refusal "unknown polarity" "$work/b7" --polarity grey
expect_refusal "zero relief" "$work/b8" --relief-um 0
for d in b1 b2 b3 b4 b5 b6 b7 b8; do
  [ -e "$work/$d" ] && fail "$d: the output folder was created although the input was bad"
done

touch "$work/plainfile"
expect_refusal "output under a regular file" "$work/plainfile/sub"
expect_refusal "output is a regular file" "$work/plainfile"
[ -s "$work/plainfile" ] && fail "the regular file was overwritten"

mkdir "$work/readonly"
chmod 555 "$work/readonly"
if [ -w "$work/readonly" ]; then
  # Root ignores permissions; /proc refuses new entries to everyone.
  echo "note: running as root, testing an unwritable /proc path instead of a read-only folder"
  expect_refusal "unwritable output folder" "/proc/tactres-generate-test"
else
  expect_refusal "read-only output folder" "$work/readonly"
fi

# A failure at the very last step (renaming into place) undoes the renames
# already done: target.png is a folder, so the third rename fails.
mkdir -p "$work/late/target.png"
keep="target.png"
expect_refusal "rename fails midway" "$work/late"
keep=""
[ -d "$work/late/target.png" ] || fail "the blocking folder vanished"

if [ "$failures" -ne 0 ]; then
  echo "$failures failure(s)" >&2
  exit 1
fi
echo "all generate checks passed"
