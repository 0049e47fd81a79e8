#!/usr/bin/env bash
# End-to-end test of `tactres report` on the command line: a good run writes
# the CSV and the HTML and says where; every bad input exits 3 with a clear
# message on stderr and leaves no report (nor a temporary file) behind.
# Usage: report_cli_test.sh PATH/TO/tactres SOURCE_DIR
set -u
tactres="$1"
data="$2/tests/data/report"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
failures=0
fail() { echo "FAIL: $*" >&2; failures=$((failures + 1)); }

# --- A good run -----------------------------------------------------------------
mkdir "$work/good"
"$tactres" report "$data"/T*.json --reference "$data/cmos.json" --csv "$work/good/r.csv" --html "$work/good/r.html" \
  >"$work/stdout" 2>"$work/stderr"
rc=$?
[ "$rc" -eq 0 ] || fail "good run exited $rc: $(cat "$work/stderr")"
[ -s "$work/good/r.csv" ] || fail "no CSV"
[ -s "$work/good/r.html" ] || fail "no HTML"
[ "$(ls -A "$work/good" | wc -l)" -eq 2 ] || fail "expected exactly the two outputs, found: $(ls -A "$work/good")"
grep -q "^CSV: $work/good/r.csv$" "$work/stdout" || fail "stdout does not say where the CSV is: $(cat "$work/stdout")"
grep -q "^HTML: $work/good/r.html$" "$work/stdout" || fail "stdout does not say where the HTML is"
grep -q "T2C4 *failed: T2C4.json: no target found" "$work/stdout" || fail "the failed design is not shown as failed"
head -n 1 "$work/good/r.csv" | grep -q '^role,design,n,n_failed,status,h_group,' || fail "CSV header changed"
grep -q '^design,T1C2,3,0,ok,' "$work/good/r.csv" || fail "the three T1C2 presses are not one row of n = 3"
grep -q '^reference,cmos,1,0,reference,' "$work/good/r.csv" || fail "no reference row"

# The reference named among the results (a glob such as out/*.json) is not a design.
"$tactres" report "$data"/*.json --reference "$data/cmos.json" --csv "$work/good/glob.csv" >/dev/null 2>&1 ||
  fail "a glob that includes the reference was refused"
[ "$(grep -c '^design,' "$work/good/glob.csv" 2>/dev/null)" = 8 ] || fail "the reference was counted as a design"

# --help documents units and defaults.
"$tactres" report --help >"$work/help" 2>&1 || fail "--help failed"
grep -q "lp/mm" "$work/help" || fail "--help does not give the unit"
grep -q "thumbnail-px INT=640" "$work/help" || fail "--help does not give the thumbnail default"

# --- Bad input: exit 3, a message, nothing written ---------------------------------
# expect_refusal NAME PATTERN ARGS...: exit 3, PATTERN in the message, and the
# output folder $work/out empty afterwards.
expect_refusal() {
  local name="$1" pattern="$2"
  shift 2
  rm -rf "$work/out"
  mkdir "$work/out"
  "$tactres" report "$@" >"$work/stdout" 2>"$work/stderr"
  local rc=$?
  [ "$rc" -eq 3 ] || fail "$name: exit code $rc, expected 3"
  grep -q -- "$pattern" "$work/stderr" || fail "$name: message lacks \"$pattern\": $(cat "$work/stderr")"
  local left
  left="$(ls -A "$work/out")"
  [ -z "$left" ] || fail "$name: left files behind: $left"
  echo "ok: $name -> $(head -n 1 "$work/stderr")"
}
out_args=(--html "$work/out/r.html" --csv "$work/out/r.csv")

expect_refusal "no reference" "no reference" "$data/T1C1.json" "${out_args[@]}"
expect_refusal "empty list" "no measurement JSONs given" --reference "$data/cmos.json" "${out_args[@]}"
expect_refusal "no output named" "say where the report goes" "$data/T1C1.json" --reference "$data/cmos.json"

sed 's#"layout": "target/layout.json"#"layout": "other/layout.json"#' "$data/cmos.json" >"$work/cmos_other_layout.json"
expect_refusal "reference on another layout" "the reference $work/cmos_other_layout.json was measured on layout" \
  "$data/T1C1.json" --reference "$work/cmos_other_layout.json" "${out_args[@]}"

sed 's#"layout": "target/layout.json"#"layout": "other/layout.json"#' "$data/T1C3.json" >"$work/T1C3.json"
expect_refusal "mixed layouts" "mixed layouts" "$data/T1C1.json" "$work/T1C3.json" --reference "$data/cmos.json" \
  "${out_args[@]}"

sed 's#"threshold": 0.1#"threshold": 0.2#' "$data/T1C3.json" >"$work/T1C3_strict.json"
grep -q '"threshold": 0.2' "$work/T1C3_strict.json" || fail "test setup: the threshold was not changed"
expect_refusal "mixed criteria" "mixed criteria" "$data/T1C1.json" "$work/T1C3_strict.json" \
  --reference "$data/cmos.json" "${out_args[@]}"

# A design file that cannot be read is a failed row; the other designs are
# still reported (one bad file never stops the others).
head -c 500 "$data/T1C1.json" >"$work/truncated.json"
echo '{"schema": "tactres.target/1"}' >"$work/layout_not_measurement.json"
mkdir -p "$work/a_folder.json" "$work/rows"
"$tactres" report "$data/T1C1.json" "$work/nope.json" "$work/truncated.json" \
  "$work/a_folder.json" --reference "$data/cmos.json" --csv "$work/rows/r.csv" --html "$work/rows/r.html" \
  >"$work/stdout" 2>"$work/stderr"
rc=$?
[ "$rc" -eq 0 ] || fail "bad design files: exit $rc, expected 0: $(cat "$work/stderr")"
grep -q '^design,T1C1,1,0,ok,' "$work/rows/r.csv" || fail "bad design files: the good design is not reported"
for stem in nope truncated a_folder; do
  grep -q "^design,$stem,0,1,failed," "$work/rows/r.csv" || fail "bad design files: $stem is not a failed row"
done
grep -q "truncated *failed: $work/truncated.json is not valid JSON" "$work/stdout" ||
  fail "bad design files: the truncated file's reason is not shown: $(cat "$work/stdout")"
grep -q "a_folder *failed: cannot read $work/a_folder.json: it is a folder" "$work/stdout" ||
  fail "bad design files: the folder's reason is not shown"
grep -q "4 design(s) from 4 measurement(s).*; 3 failed" "$work/stdout" || fail "bad design files: the count line"
echo "ok: unreadable design files are failed rows"
# Another tactres file (a layout caught by a glob) is no design's: refused.
expect_refusal "not a measurement" "$work/layout_not_measurement.json is not a tactres measurement" \
  "$data/T1C1.json" "$work/layout_not_measurement.json" --reference "$data/cmos.json" "${out_args[@]}"
# A failed press joins its design when the file still names it.
sed 's#"usable": true#"usable": "yes"#' "$data/T1C2_press3.json" >"$work/T1C2_bad_press.json"
"$tactres" report "$data/T1C1.json" "$data/T1C2_press1.json" "$work/T1C2_bad_press.json" --reference "$data/cmos.json" \
  --csv "$work/rows/p.csv" >/dev/null 2>&1 || fail "a malformed press: refused"
grep -q "^design,T1C2,[0-9]*,1,partly_failed," "$work/rows/p.csv" ||
  fail "a malformed press is not a failed press of its design: $(cat "$work/rows/p.csv")"
# A missing file given twice, spelt two ways, is still given twice.
expect_refusal "missing file given twice" "given twice" "$data/T1C1.json" "$work/nope.json" "$work/./nope.json" \
  --reference "$data/cmos.json" "${out_args[@]}"
# An unreadable reference is refused: every percentage needs it.
expect_refusal "truncated reference" "$work/truncated.json is not valid JSON" "$data/T1C1.json" \
  --reference "$work/truncated.json" "${out_args[@]}"
expect_refusal "failed reference" "is a failed measurement" "$data/T1C1.json" --reference "$data/T2C4.json" \
  "${out_args[@]}"
expect_refusal "file given twice" "given twice" "$data/T1C1.json" "$data/../report/T1C1.json" \
  --reference "$data/cmos.json" "${out_args[@]}"
# Chart.js missing: not even the CSV (which could have been written) is left.
expect_refusal "Chart.js missing" "libjs-chart.js" "$data/T1C1.json" --reference "$data/cmos.json" \
  --chart-js "$work/no-chart.js" "${out_args[@]}"
expect_refusal "bad thumbnail size" "thumbnail size" "$data/T1C1.json" --reference "$data/cmos.json" \
  --thumbnail-px 0 "${out_args[@]}"
expect_refusal "output folder missing" "cannot write $work/out/missing/r.csv" "$data/T1C1.json" \
  --reference "$data/cmos.json" --csv "$work/out/missing/r.csv"

# A refusal leaves an earlier report as it was.
echo "old report" >"$work/old.csv"
"$tactres" report --reference "$data/cmos.json" --csv "$work/old.csv" >/dev/null 2>&1
[ "$(cat "$work/old.csv")" = "old report" ] || fail "a refused run changed the existing report"

if [ "$failures" -ne 0 ]; then
  echo "$failures failure(s)" >&2
  exit 1
fi
echo "all report CLI checks passed"
