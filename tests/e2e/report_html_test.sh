#!/usr/bin/env bash
# Browser test of the `tactres report` HTML: headless Chromium, with no
# network, loads the page and we read back the rendered DOM. The fixtures in
# tests/data/report are 8 designs (one failed, one pressed 3 times) and the
# reference: the table must have 9 rows, and Chart.js must have drawn the 3
# charts. The checks are then run on a broken report (a design removed, and
# a Chart.js that does not draw) to show that they can fail.
# Usage: report_html_test.sh PATH/TO/tactres SOURCE_DIR [SCREENSHOT_DIR]
set -u
tactres="$1"
src="$2"
shots="${3:-}"
data="$src/tests/data/report"
chromium="${CHROMIUM:-/usr/bin/chromium}"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
failures=0
fail() { echo "FAIL: $*" >&2; failures=$((failures + 1)); }

if [ ! -x "$chromium" ]; then
  echo "FAIL: headless Chromium ($chromium) is missing: run scripts/install-deps.sh (Debian package chromium)" >&2
  exit 1
fi

# browse MODE FILE OUT: runs Chromium on FILE with a fresh profile and no
# network (every host name fails to resolve, and any proxy use hits a closed
# local port). MODE is dom (rendered DOM to OUT) or shot (PNG to OUT).
browse() {
  local mode="$1" file="$2" out="$3" profile
  profile="$(mktemp -d "$work/profile.XXXXXX")"
  local flags=(--headless --no-sandbox --disable-gpu --disable-background-networking --disable-component-update
    --disable-sync --no-first-run --user-data-dir="$profile" --host-resolver-rules="MAP * ~NOTFOUND"
    --proxy-server="127.0.0.1:9" --virtual-time-budget=5000 --window-size=1280,2000 --hide-scrollbars)
  if [ "$mode" = dom ]; then
    timeout 120 "$chromium" "${flags[@]}" --dump-dom "file://$file" >"$out" 2>"$work/chromium.log"
  else
    timeout 120 "$chromium" "${flags[@]}" --screenshot="$out" "file://$file" >/dev/null 2>"$work/chromium.log"
  fi
  local rc=$?
  [ "$rc" -eq 0 ] || echo "chromium exited $rc: $(tail -n 3 "$work/chromium.log")" >&2
  return "$rc"
}

# check_dom DOM DESIGNS: prints every problem with the rendered page; exits
# non-zero if there is one.
check_dom() {
  local dom="$1" designs="$2" bad=0 n
  n=$(grep -o 'data-row="design"' "$dom" | wc -l)
  [ "$n" -eq "$designs" ] || { echo "table has $n design rows, expected $designs"; bad=1; }
  n=$(grep -o 'data-row="reference"' "$dom" | wc -l)
  [ "$n" -eq 1 ] || { echo "table has $n reference rows, expected 1"; bad=1; }
  # The page's script sets these on <body> (the script's own text names them too).
  local body
  body=$(grep -o '<body[^>]*>' "$dom" | head -n 1)
  echo "$body" | grep -q 'data-charts-rendered="3"' ||
    { echo "charts rendered: $(echo "$body" | grep -o 'data-charts-rendered="[0-9]*"'), expected 3"; bad=1; }
  echo "$body" | grep -q 'data-script-error' &&
    { echo "script error: $(echo "$body" | grep -o 'data-script-error="[^"]*"')"; bad=1; }
  local sizes
  sizes=$(grep -o 'data-rendered-size="[0-9]*x[0-9]*"' "$dom" | grep -cv 'data-rendered-size="0x\|x0"')
  [ "$sizes" -eq 3 ] || { echo "$sizes canvases were drawn at a non-zero size, expected 3"; bad=1; }
  return "$bad"
}

# --- The fixtures: 9 rows, 3 charts --------------------------------------------
"$tactres" report "$data"/T*.json --reference "$data/cmos.json" --html "$work/report.html" \
  --csv "$work/report.csv" >"$work/stdout" 2>"$work/stderr"
rc=$?
[ "$rc" -eq 0 ] || fail "report exited $rc: $(cat "$work/stderr")"
grep -q "HTML: $work/report.html" "$work/stdout" || fail "report does not say where the HTML is: $(cat "$work/stdout")"
grep -q "CSV: $work/report.csv" "$work/stdout" || fail "report does not say where the CSV is"
[ "$(wc -l <"$work/report.csv")" -eq 10 ] || fail "CSV should have a header and 9 rows: $(cat "$work/report.csv")"

# Self-contained: no element loads anything from elsewhere.
if grep -Eiq '(src|href)[[:space:]]*=[[:space:]]*["'"'"']?(https?:|//|file:)|<link|@import|url\((["'"'"']?)(https?:|//)' \
  "$work/report.html"; then
  fail "the HTML refers to an external resource"
fi

if browse dom "$work/report.html" "$work/dom.html"; then
  if problems=$(check_dom "$work/dom.html" 8); then
    echo "ok: 9 table rows (8 designs + reference) and 3 charts drawn"
  else
    fail "rendered page: $problems"
  fi
  n=$(grep -o 'data-status="failed"' "$work/dom.html" | wc -l)
  [ "$n" -eq 1 ] || fail "expected 1 failed design row, found $n"
  n=$(grep -o '<img src="data:image/' "$work/dom.html" | wc -l)
  [ "$n" -eq 4 ] || fail "expected 4 embedded overlay thumbnails (the fixtures that have one), found $n"
  grep -q 'T1C2_press2.overlay.png is missing' "$work/dom.html" || fail "a missing overlay is not explained"
else
  fail "chromium could not load the report"
fi

if browse shot "$work/report.html" "$work/report.png"; then
  size=$(stat -c %s "$work/report.png" 2>/dev/null || echo 0)
  # A blank or unstyled page compresses to a few kB; this one has charts.
  [ "$size" -gt 60000 ] || fail "the screenshot is only $size bytes: is the page blank?"
  [ -n "$shots" ] && cp "$work/report.png" "$shots/report-screenshot.png" && echo "screenshot: $shots/report-screenshot.png"
else
  fail "chromium could not take a screenshot"
fi

# --- measurement/2 files: the CNR(f) charts too -----------------------------------
# tests/data/report_v2: the main job's cmos, T1C1 and T2C1 measurements,
# with detectability: m(f) and CNR(f) per orientation plus the bar chart.
v2="$src/tests/data/report_v2"
"$tactres" report "$v2"/T*.json --reference "$v2/cmos.json" --html "$work/v2.html" >/dev/null 2>"$work/v2.err" ||
  fail "report on measurement/2 files failed: $(cat "$work/v2.err")"
if browse dom "$work/v2.html" "$work/v2.dom"; then
  body=$(grep -o '<body[^>]*>' "$work/v2.dom" | head -n 1)
  if echo "$body" | grep -q 'data-charts-rendered="5"' && ! echo "$body" | grep -q 'data-script-error'; then
    echo "ok: measurement/2 page draws 5 charts (bars, m(f) and CNR(f) per orientation)"
  else
    fail "measurement/2 page: $(echo "$body" | grep -o 'data-[a-z-]*="[^"]*"' | tr '\n' ' '), expected 5 charts"
  fi
  grep -q 'Rose threshold' "$work/v2.dom" || grep -q 'Rose' "$work/v2.html" || fail "measurement/2 page does not name the Rose threshold"
else
  fail "chromium could not load the measurement/2 report"
fi

# --- The checks can fail ------------------------------------------------------
# One design fewer: the row count no longer matches.
mkdir -p "$work/fewer"
cp "$data"/*.json "$work/fewer/"
rm "$work/fewer/T2C2.json"
"$tactres" report "$work/fewer"/T*.json --reference "$work/fewer/cmos.json" --html "$work/fewer.html" >/dev/null 2>&1 ||
  fail "report on 7 designs failed"
if browse dom "$work/fewer.html" "$work/fewer.dom"; then
  if problems=$(check_dom "$work/fewer.dom" 8); then
    fail "the row check passed with a design missing"
  else
    echo "ok: a missing design is caught ($problems)"
  fi
fi
# A Chart.js that draws nothing: the chart check fails.
echo 'window.Chart = function () {}; window.Chart.defaults = {font: {}}; window.Chart.register = function () {};' \
  >"$work/inert-chart.js"
"$tactres" report "$data"/T*.json --reference "$data/cmos.json" --html "$work/inert.html" \
  --chart-js "$work/inert-chart.js" >/dev/null 2>&1 || fail "report with a stand-in Chart.js failed"
if browse dom "$work/inert.html" "$work/inert.dom"; then
  if problems=$(check_dom "$work/inert.dom" 8); then
    fail "the chart check passed although nothing was drawn"
  else
    echo "ok: undrawn charts are caught ($(echo "$problems" | head -n 1))"
  fi
fi

if [ "$failures" -ne 0 ]; then
  echo "$failures failure(s)" >&2
  exit 1
fi
echo "all report HTML checks passed"
