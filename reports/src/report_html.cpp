#include "tactres/reports/report_html.h"

#include <algorithm>
#include <cmath>
#include <set>
#include <stdexcept>
#include <vector>

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>
#include <OpenImageIO/strutil.h>
#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "tactres/util/atomic_file.h"

namespace tactres {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// ---------------------------------------------------------------------------
// The report's own style, after the shared one (html_page.cpp). Print CSS
// keeps the table and each chart on one page.
constexpr const char* kReportCss = R"CSS(
:root { --h: #1f5fa8; --v: #d9731a; --ref: #38414f; }
.card .val { font-size: 19px; white-space: nowrap; }
thead tr:first-child th.grp { text-align: center; border-bottom: 2px solid var(--line); color: var(--ink); }
th.grp.h { border-bottom-color: var(--h) !important; }
th.grp.v { border-bottom-color: var(--v) !important; }
td.sep, th.sep { border-left: 1px solid var(--line); }
tr.reference { background: #eef1f5 !important; }
tr.reference td.name::after { content: "reference"; margin-left: 8px; font-size: 11px; font-weight: 400;
                              color: #fff; background: var(--ref); border-radius: 3px; padding: 1px 5px; }
tr.failed td { color: var(--muted); }
td.problem { color: var(--bad) !important; }  /* also in a failed row (tr.failed td) */
td.rank { font-weight: 700; }
.pct { background: linear-gradient(to right, rgba(31, 95, 168, 0.55) var(--w), rgba(31, 95, 168, 0.08) var(--w))
        no-repeat left bottom 3px / 100% 3px; }
.status-ok { color: var(--ok); }
.status-failed, .status-partly_failed { color: var(--bad); font-weight: 600; }
.status-reference { color: var(--ref); }
.pm { color: var(--muted); }
.chart-box { height: 420px; }
.curves { display: grid; grid-template-columns: 1fr 1fr; gap: 18px; }
.curves .chart-box { height: 380px; }
.curves h3 { font-size: 14px; margin: 0 0 6px; }
.thumbs { display: grid; grid-template-columns: repeat(auto-fill, minmax(260px, 1fr)); gap: 14px; }
figure.thumb { margin: 0; border: 1px solid var(--line); border-radius: 6px; overflow: hidden; background: #fff; }
figure.thumb img { display: block; width: 100%; height: auto; cursor: zoom-in; background: #222; }
figure.thumb.enlarged { grid-column: 1 / -1; }
figure.thumb.enlarged img { cursor: zoom-out; }
figure.thumb figcaption { padding: 6px 9px; font-size: 12.5px; }
figure.thumb figcaption .file { color: var(--muted); display: block; overflow-wrap: anywhere; }
figure.thumb .placeholder { aspect-ratio: 16 / 9; display: flex; align-items: center; justify-content: center;
                            text-align: center; padding: 14px; color: var(--muted); background: repeating-linear-gradient(
                            45deg, #f3f4f6, #f3f4f6 10px, #eceef1 10px, #eceef1 20px); font-size: 12.5px; }
table.inputs td, table.inputs th { text-align: left; white-space: normal; font-size: 12.5px; }
table.inputs td.file { white-space: nowrap; font-family: "DejaVu Sans Mono", monospace; font-size: 11.5px; }
footer p { margin: 4px 0; }
@media (max-width: 900px) { .curves { grid-template-columns: 1fr; } }
@media print {
  section { margin: 0 0 8mm; }
  h2, h3 { break-after: avoid; }
  .card, figure.thumb, .chart-box, .curves { break-inside: avoid; }
  #bars, #curves, #overlays { break-before: page; }
  /* The charts keep their aspect ratio when the page is narrower than the
     screen they were drawn for (Chart.js also redraws them on beforeprint). */
  canvas { height: auto !important; }
  .chart-box { height: auto; }
  figure.thumb img { cursor: default; }
  .thumbs { grid-template-columns: repeat(4, 1fr); }
  .curves { grid-template-columns: 1fr 1fr; }
}
)CSS";

// ---------------------------------------------------------------------------
// The report's charts, inside the shared page script (html_page.h: `data`,
// `body`, the rendered-charts counter and textLabels are set up there).
// Small Chart.js plugins: error bars, value labels, failed marks and
// labelled reference lines.
constexpr const char* kReportChartScript = R"JS(
    var H = '#1f5fa8', V = '#d9731a';
    var palette = ['#0072b2', '#d55e00', '#009e73', '#cc79a7', '#56b4e9', '#e69f00', '#6a3d9a', '#8c564b',
                   '#17becf', '#bcbd22', '#7f7f7f', '#1b9e77'];
    var colourOf = {};
    data.designs.forEach(function (d, i) { colourOf[d.design] = palette[i % palette.length]; });

    function valueOf(raw) {
      if (raw === null || raw === undefined) return null;
      return typeof raw === 'object' ? raw.y : raw;
    }

    // dataset.errorBars[i]: the 1-sigma half length at data point i (or null).
    var errorBars = {
      id: 'errorBars',
      afterDatasetsDraw: function (chart) {
        var ctx = chart.ctx, area = chart.chartArea;
        ctx.save();
        ctx.beginPath();
        ctx.rect(area.left, area.top, area.right - area.left, area.bottom - area.top);
        ctx.clip();
        chart.data.datasets.forEach(function (ds, di) {
          if (!ds.errorBars || !chart.isDatasetVisible(di)) return;
          var meta = chart.getDatasetMeta(di), y = chart.scales[meta.yAxisID];
          meta.data.forEach(function (el, i) {
            var s = ds.errorBars[i], v = valueOf(ds.data[i]);
            if (v === null || !(s > 0)) return;
            var top = y.getPixelForValue(v + s), bottom = y.getPixelForValue(v - s);
            var cap = el.width ? Math.max(3, Math.min(7, el.width / 5)) : 3;
            ctx.strokeStyle = ds.errorBarColor || '#222';
            ctx.lineWidth = ds.errorBarWidth || 1.2;
            ctx.beginPath();
            ctx.moveTo(el.x, top); ctx.lineTo(el.x, bottom);
            ctx.moveTo(el.x - cap, top); ctx.lineTo(el.x + cap, top);
            ctx.moveTo(el.x - cap, bottom); ctx.lineTo(el.x + cap, bottom);
            ctx.stroke();
          });
        });
        ctx.restore();
      }
    };

    // dataset.valueLabels[i]: text drawn above bar i (above its error bar).
    var valueLabels = textLabels('valueLabels', '600 10.5px', 'center', 'bottom', function (chart, ds, meta, el, i) {
      var v = valueOf(ds.data[i]);
      if (v === null) return null;
      var top = chart.scales[meta.yAxisID].getPixelForValue(v + ((ds.errorBars && ds.errorBars[i]) || 0));
      return [el.x, top - 3];
    });

    // options.plugins.failedMarks.indices: categories drawn as "failed".
    var failedMarks = {
      id: 'failedMarks',
      afterDatasetsDraw: function (chart, args, opts) {
        var ctx = chart.ctx, x = chart.scales.x, a = chart.chartArea;
        ctx.save();
        ctx.font = '600 12px ' + Chart.defaults.font.family;
        ctx.fillStyle = '#b3261e'; ctx.textAlign = 'center'; ctx.textBaseline = 'bottom';
        ((opts && opts.indices) || []).forEach(function (i) {
          ctx.fillText('failed', x.getPixelForValue(i), a.bottom - 6);
        });
        ctx.restore();
      }
    };

    // options.plugins.refLines.lines: [{y | x, label, color, dash, align}].
    var refLines = {
      id: 'refLines',
      afterDatasetsDraw: function (chart, args, opts) {
        var lines = (opts && opts.lines) || [], ctx = chart.ctx, a = chart.chartArea;
        ctx.save();
        lines.forEach(function (l) {
          var horizontal = l.y !== undefined;
          var scale = horizontal ? chart.scales.y : chart.scales.x;
          var p = scale.getPixelForValue(horizontal ? l.y : l.x);
          if (!isFinite(p) || (horizontal ? (p < a.top || p > a.bottom) : (p < a.left || p > a.right))) return;
          ctx.strokeStyle = l.color; ctx.lineWidth = l.width || 1.6; ctx.setLineDash(l.dash || []);
          ctx.beginPath();
          if (horizontal) { ctx.moveTo(a.left, p); ctx.lineTo(a.right, p); }
          else { ctx.moveTo(p, a.top); ctx.lineTo(p, a.bottom); }
          ctx.stroke();
          ctx.setLineDash([]);
          if (!l.label) return;
          ctx.font = '600 11px ' + Chart.defaults.font.family;
          var w = ctx.measureText(l.label).width + 8, hgt = 16, x, yy;
          if (horizontal) {
            x = l.align === 'left' ? a.left + 6 : a.right - w - 6;
            yy = l.below ? p + 3 : p - hgt - 3;
          } else {
            x = p + w + 5 > a.right ? p - w - 5 : p + 5; yy = a.top + 4;
          }
          ctx.fillStyle = 'rgba(255,255,255,0.88)';
          ctx.fillRect(x, yy, w, hgt);
          ctx.fillStyle = l.color; ctx.textBaseline = 'middle'; ctx.textAlign = 'left';
          ctx.fillText(l.label, x + 4, yy + hgt / 2);
        });
        ctx.restore();
      }
    };

    function fmt(v, d) { return v === null || v === undefined ? '–' : v.toFixed(d); }
    var ref = data.reference, nyq = data.nyquist;
    var refName = ref.design;

    // 1. Grouped bars: H and V limit per design, error bars, raw CMOS lines.
    (function () {
      var ds = data.designs;
      var labels = ds.map(function (d) { return d.status === 'failed' ? [d.design, '(failed)'] : d.design; });
      function series(k, f) { return ds.map(function (d) { return d[k] ? f(d[k]) : null; }); }
      var ymax = 0;
      ds.forEach(function (d) {
        ['h', 'v'].forEach(function (k) {
          if (d[k] && d[k].value !== null) ymax = Math.max(ymax, d[k].value + (d[k].sigma || 0));
        });
      });
      var lines = [];
      if (ref.h.value !== null) {
        lines.push({ y: ref.h.value, color: H, dash: [7, 4], align: 'left', below: ref.v.value !== null && ref.v.value > ref.h.value,
                     label: 'raw CMOS, horizontal bars ' + fmt(ref.h.value, 2) + ' lp/mm' });
        ymax = Math.max(ymax, ref.h.value);
      }
      if (ref.v.value !== null) {
        lines.push({ y: ref.v.value, color: V, dash: [7, 4], align: 'right', below: ref.h.value !== null && ref.h.value > ref.v.value,
                     label: 'raw CMOS, vertical bars ' + fmt(ref.v.value, 2) + ' lp/mm' });
        ymax = Math.max(ymax, ref.v.value);
      }
      if (nyq.h > 0) {
        var same = nyq.v > 0 && Math.abs(nyq.h - nyq.v) < 0.005 * nyq.h;
        lines.push({ y: nyq.h, color: '#6b7280', dash: [2, 3], align: 'right',
                     label: (same ? 'camera sampling (Nyquist) limit ' : 'Nyquist, horizontal bars ') + fmt(nyq.h, 2) + ' lp/mm' });
        if (!same && nyq.v > 0)
          lines.push({ y: nyq.v, color: '#6b7280', dash: [2, 3], align: 'left', label: 'Nyquist, vertical bars ' + fmt(nyq.v, 2) + ' lp/mm' });
        ymax = Math.max(ymax, nyq.h, nyq.v);
      }
      function dataset(k, label, colour) {
        return {
          label: label, data: series(k, function (o) { return o.value; }),
          errorBars: series(k, function (o) { return o.sigma; }),
          valueLabels: series(k, function (o) { return o.pct === null ? null : Math.round(o.pct) + '%'; }),
          backgroundColor: colour + 'bf', borderColor: colour, borderWidth: 1, errorBarColor: '#1d2330',
          barPercentage: 0.9, categoryPercentage: 0.72
        };
      }
      new Chart(document.getElementById('chart-bars'), {
        type: 'bar',
        data: { labels: labels, datasets: [dataset('h', 'Horizontal bars', H), dataset('v', 'Vertical bars', V)] },
        plugins: [errorBars, valueLabels, refLines, failedMarks],
        options: {
          layout: { padding: { top: 8 } },
          scales: {
            y: { beginAtZero: true, suggestedMax: ymax * 1.1, title: { display: true, text: 'resolution limit (lp/mm)' } },
            x: { grid: { display: false } }
          },
          plugins: {
            legend: { position: 'top' },
            refLines: { lines: lines },
            failedMarks: { indices: ds.map(function (d, i) { return d.status === 'failed' ? i : -1; })
                                      .filter(function (i) { return i >= 0; }) },
            tooltip: { callbacks: { label: function (c) {
              var o = ds[c.dataIndex][c.dataset.label === 'Horizontal bars' ? 'h' : 'v'];
              if (!o || o.value === null) return c.dataset.label + ': none';
              return c.dataset.label + ': ' + fmt(o.value, 2) + (o.sigma ? ' ± ' + fmt(o.sigma, 2) : '') + ' lp/mm' +
                (o.pct === null ? '' : ' (' + fmt(o.pct, 1) + '% of raw CMOS)') + (o.interpolated ? '' : ', discrete');
            } } }
          }
        }
      });
    })();

    // 2, 3. m(f) per press, one chart per orientation, criterion line.
    function curveChart(id, key) {
      var datasets = [], fmin = Infinity, fmax = 0, mmin = 0;
      data.curves.forEach(function (c) {
        var pts = c[key];
        if (!pts.length) return;
        var colour = c.reference ? '#111111' : colourOf[c.design];
        pts.forEach(function (p) { fmin = Math.min(fmin, p.f); fmax = Math.max(fmax, p.f); mmin = Math.min(mmin, p.m - p.s); });
        datasets.push({
          label: c.reference ? c.design + ' (raw CMOS)' : c.design,
          data: pts.map(function (p) { return { x: p.f, y: p.m }; }),
          points: pts, file: c.file,
          errorBars: pts.map(function (p) { return p.s; }), errorBarColor: colour, errorBarWidth: 1,
          borderColor: colour, backgroundColor: colour, showLine: true, tension: 0,
          borderWidth: c.reference ? 2.4 : 1.5, borderDash: c.reference ? [6, 3] : [],
          pointRadius: 2.2, pointHoverRadius: 4, hideInLegend: !c.first_of_design, order: c.reference ? 0 : 1
        });
      });
      if (!datasets.length) { fmin = 1; fmax = 10; }
      var lines = [{ y: data.threshold, color: '#b3261e', dash: [6, 4], align: 'left', label: 'criterion m = ' + data.threshold }];
      var n = key === 'h' ? nyq.h : nyq.v;
      if (n > 0) lines.push({ x: n, color: '#6b7280', dash: [2, 3], label: 'Nyquist ' + fmt(n, 2) });
      new Chart(document.getElementById(id), {
        type: 'scatter',
        data: { datasets: datasets },
        plugins: [errorBars, refLines],
        options: {
          scales: {
            x: { type: 'logarithmic', min: fmin / 1.12, max: Math.max(fmax, n || 0) * 1.12,
                 title: { display: true, text: 'spatial frequency (lp/mm, log scale)' },
                 ticks: { autoSkip: false, callback: function (v) {
                   var r = Math.round(v * 1000) / 1000;
                   return [0.5, 1, 2, 3, 5, 10, 20, 30, 50, 100, 200].indexOf(r) >= 0 ? String(r) : '';
                 } } },
            y: { min: Math.min(0, Math.floor(mmin * 10) / 10), max: 1.05, title: { display: true, text: 'modulation m(f)' } }
          },
          plugins: {
            legend: { position: 'top', labels: { boxWidth: 14, filter: function (item, d) {
              return !d.datasets[item.datasetIndex].hideInLegend; } } },
            refLines: { lines: lines },
            tooltip: { callbacks: { label: function (c) {
              var p = c.dataset.points[c.dataIndex];
              return c.dataset.label + ': G' + p.g + 'E' + p.e + ' ' + fmt(p.f, 2) + ' lp/mm, m = ' + fmt(p.m, 3) + ' ± ' + fmt(p.s, 3);
            } } }
          }
        }
      });
    }
    curveChart('chart-mtf-h', 'h');
    curveChart('chart-mtf-v', 'v');

    // Charts follow the page size when printing, and back.
    ['beforeprint', 'afterprint'].forEach(function (ev) {
      window.addEventListener(ev, function () {
        Object.values(Chart.instances).forEach(function (c) { c.resize(); });
      });
    });
)JS";

// Thumbnails: a click shows one at full width and back (charts or not).
constexpr const char* kReportAfterScript = R"JS(
  document.querySelectorAll('figure.thumb img').forEach(function (img) {
    img.addEventListener('click', function () { img.parentElement.classList.toggle('enlarged'); });
  });
)JS";

// ---------------------------------------------------------------------------

std::string esc(std::string_view s) { return html_escape(s); }

std::string join(const std::vector<std::string>& parts, std::string_view sep) {
  std::string out;
  for (const std::string& p : parts) {
    if (!out.empty()) out += sep;
    out += p;
  }
  return out;
}

std::string num(double v, int digits) { return fmt::format("{:.{}f}", v, digits); }

json opt_json(std::optional<double> v) { return v ? json(*v) : json(); }

json orientation_json(const OrientationSummary& o) {
  return {{"value", opt_json(o.value_lp_per_mm())},
          {"interpolated", o.interp_lp_per_mm.has_value()},
          {"sigma", opt_json(o.interp_sigma_lp_per_mm)},
          {"pct", opt_json(o.pct_of_reference)}};
}

json curve_points(const MeasurementRecord& m, BarOrientation o) {
  std::vector<const ElementRecord*> ok;
  for (const ElementRecord& e : m.elements)
    if (e.orientation == o && e.status == "ok" && e.m && e.m_sigma) ok.push_back(&e);
  std::sort(ok.begin(), ok.end(), [](const ElementRecord* a, const ElementRecord* b) { return a->lp_per_mm < b->lp_per_mm; });
  json pts = json::array();
  for (const ElementRecord* e : ok)
    pts.push_back({{"f", e->lp_per_mm}, {"m", *e->m}, {"s", *e->m_sigma}, {"g", e->group}, {"e", e->element}});
  return pts;
}

json page_data(const Comparison& c) {
  json d;
  d["threshold"] = c.threshold;
  d["nyquist"] = {{"h", c.nyquist_h_lp_per_mm}, {"v", c.nyquist_v_lp_per_mm}};
  d["reference"] = {{"design", c.reference_row.design},
                    {"h", orientation_json(c.reference_row.horizontal)},
                    {"v", orientation_json(c.reference_row.vertical)}};
  d["designs"] = json::array();
  for (const DesignRow& r : c.designs) {
    json row = {{"design", r.design}, {"status", to_string(r.status)}, {"rank", r.rank ? json(*r.rank) : json()}};
    if (r.n > 0) {
      row["h"] = orientation_json(r.horizontal);
      row["v"] = orientation_json(r.vertical);
    } else {
      row["h"] = row["v"] = nullptr;
    }
    d["designs"].push_back(row);
  }
  d["curves"] = json::array();
  auto add_curve = [&](const MeasurementRecord& m, bool reference, bool first) {
    if (!m.usable) return;
    d["curves"].push_back({{"design", m.design},
                           {"reference", reference},
                           {"first_of_design", first},
                           {"file", m.path.filename().string()},
                           {"h", curve_points(m, BarOrientation::horizontal_bars)},
                           {"v", curve_points(m, BarOrientation::vertical_bars)}});
  };
  add_curve(c.reference, true, true);
  for (const DesignRow& r : c.designs) {
    bool first = true;
    for (size_t i : r.presses) {
      if (!c.measurements[i].usable) continue;
      add_curve(c.measurements[i], false, first);
      first = false;
    }
  }
  return d;
}

// ---------------------------------------------------------------------------
// The table.

std::string pct_cell(std::optional<double> pct, const char* extra_class = "") {
  if (!pct) return fmt::format("<td class=\"{}\">–</td>", extra_class);
  const double w = std::clamp(*pct, 0.0, 100.0);
  return fmt::format("<td class=\"pct {}\" style=\"--w:{:.1f}%\">{:.1f}&thinsp;%</td>", extra_class, w, *pct);
}

std::string orientation_cells(const OrientationSummary& o, int n) {
  std::string s;
  if (o.resolved_any) {
    s += fmt::format("<td class=\"sep\">G{}&thinsp;E{}</td>", o.group, o.element);
    s += fmt::format("<td>{}{}</td>", o.beyond_finest ? "&ge;&thinsp;" : "", num(o.lp_per_mm, 2));
  } else {
    s += "<td class=\"sep\" colspan=\"2\" title=\"no element resolved: the limit is below the coarsest element\">none "
         "resolved</td>";
  }
  if (o.interp_lp_per_mm) {
    std::string title;
    if (n >= 2)
      title = fmt::format("mean of {} presses; sample SD {}; ± combines the SD and the mean uncertainty", n,
                          o.interp_sd_lp_per_mm ? num(*o.interp_sd_lp_per_mm, 3) : "–");
    else
      title = "the measurement's 1-sigma uncertainty";
    s += fmt::format("<td title=\"{}\">{}{}</td>", esc(title), num(*o.interp_lp_per_mm, 2),
                     o.interp_sigma_lp_per_mm
                         ? fmt::format(" <span class=\"pm\">± {}</span>", num(*o.interp_sigma_lp_per_mm, 2))
                         : std::string());
  } else {
    s += "<td title=\"no crossing could be interpolated: the comparison uses the discrete limit\">–</td>";
  }
  s += pct_cell(o.pct_of_reference);
  return s;
}

std::string table_row(const DesignRow& r) {
  const bool ref = r.status == RowStatus::reference;
  const char* role = ref ? "reference" : "design";
  std::string cls = ref ? "reference" : r.status == RowStatus::failed ? "design failed" : "design";
  std::string s = fmt::format("<tr class=\"{}\" data-row=\"{}\" data-design=\"{}\" data-status=\"{}\">", cls, role,
                              esc(r.design), to_string(r.status));
  s += fmt::format("<td class=\"rank\">{}</td>", r.rank ? std::to_string(*r.rank) : "–");
  s += fmt::format("<td class=\"name\">{}</td>", esc(r.design));
  s += fmt::format("<td>{}</td>", r.n_failed ? fmt::format("{}/{}", r.n, r.n + r.n_failed) : std::to_string(r.n));
  if (r.n == 0) {
    std::vector<std::string> problems;
    for (const std::string& p : r.problems) problems.push_back(esc(p));
    s += fmt::format("<td class=\"sep problem\" colspan=\"10\">failed: {}</td>", join(problems, "<br>"));
  } else {
    s += orientation_cells(r.horizontal, r.n);
    s += orientation_cells(r.vertical, r.n);
    s += fmt::format("<td class=\"sep\">{}</td>", r.mean_hv_lp_per_mm ? num(*r.mean_hv_lp_per_mm, 2) : "–");
    s += pct_cell(r.mean_pct_of_reference);
  }
  std::string status = to_string(r.status);
  if (r.status == RowStatus::partly_failed) status = fmt::format("{} of {} failed", r.n_failed, r.n + r.n_failed);
  if (r.status == RowStatus::reference) status = "raw CMOS";
  const std::string title = join(r.problems, "\n");
  s += fmt::format("<td class=\"sep status-{}\"{}>{}</td></tr>\n", to_string(r.status),
                   title.empty() ? "" : fmt::format(" title=\"{}\"", esc(title)), esc(status));
  return s;
}

std::string limits_table(const Comparison& c) {
  std::string s =
      "<table class=\"limits\" id=\"limits\">\n<thead>\n"
      "<tr><th rowspan=\"2\">Rank</th><th rowspan=\"2\" class=\"name\">Design</th><th rowspan=\"2\" "
      "title=\"usable presses aggregated (of all given)\">n</th>"
      "<th colspan=\"4\" class=\"grp h sep\">Horizontal bars</th><th colspan=\"4\" class=\"grp v sep\">Vertical "
      "bars</th><th colspan=\"2\" class=\"grp sep\">Mean of H and V</th><th rowspan=\"2\" class=\"sep\">Status</th></tr>\n"
      "<tr>";
  for (int k = 0; k < 2; ++k)
    s += "<th class=\"sep\">element</th><th>discrete<br>lp/mm</th><th>interpolated<br>lp/mm ± 1σ</th><th>% of raw<br>CMOS</th>";
  s += "<th class=\"sep\">lp/mm</th><th>% of raw<br>CMOS</th></tr>\n</thead>\n<tbody>\n";
  s += table_row(c.reference_row);
  for (const DesignRow& r : c.designs) s += table_row(r);
  s += "</tbody>\n</table>\n";
  return s;
}

// ---------------------------------------------------------------------------

std::string thumbnails(const Comparison& c, int max_px) {
  std::string s = "<div class=\"thumbs\">\n";
  auto figure = [&](const MeasurementRecord& m, bool reference) {
    auto limit = [](const LimitRecord& l) {
      if (!l.resolved_any) return std::string("none");
      return num(l.interpolated_lp_per_mm.value_or(l.lp_per_mm), 2);
    };
    const std::string limits =
        m.usable ? fmt::format(" · H {} · V {} lp/mm", limit(m.horizontal), limit(m.vertical)) : " · failed";
    std::string caption = fmt::format("<b>{}</b>{}{}<span class=\"file\">{}</span>", esc(m.design),
                                      reference ? " (reference)" : "", limits, esc(m.path.filename().string()));
    std::string why;
    std::optional<std::string> uri;
    if (!m.usable)
      why = "no overlay: the measurement failed (" + m.problem + ")";
    else
      uri = thumbnail_data_uri(m.overlay_path(), max_px, &why);
    if (uri)
      s += fmt::format("<figure class=\"thumb\"><img src=\"{}\" alt=\"overlay of {}\"><figcaption>{}</figcaption></figure>\n",
                       *uri, esc(m.design), caption);
    else
      s += fmt::format("<figure class=\"thumb missing\"><div class=\"placeholder\">{}</div><figcaption>{}</figcaption></figure>\n",
                       esc(why), caption);
  };
  figure(c.reference, true);
  for (const DesignRow& r : c.designs)
    for (size_t i : r.presses) figure(c.measurements[i], false);
  return s + "</div>\n";
}

std::string inputs_table(const Comparison& c) {
  std::string s =
      "<table class=\"inputs\"><thead><tr><th>Role</th><th>Design</th><th>Measurement</th><th>Capture</th><th>Result</th>"
      "<th>Preset</th><th>tactres</th></tr></thead><tbody>\n";
  auto row = [&](const MeasurementRecord& m, const char* role) {
    s += fmt::format("<tr><td>{}</td><td>{}</td><td class=\"file\">{}</td><td class=\"file\">{}</td><td>{}</td><td>{}</td><td>{}</td></tr>\n",
                     role, esc(m.design), esc(m.path.string()), esc(m.image),
                     m.usable ? "usable" : "<span class=\"status-failed\">failed</span>: " + esc(m.problem),
                     esc(m.preset.empty() ? "–" : m.preset), esc(m.tactres_version.empty() ? "–" : m.tactres_version));
  };
  row(c.reference, "reference");
  for (const DesignRow& r : c.designs)
    for (size_t i : r.presses) row(c.measurements[i], "design");
  return s + "</tbody></table>\n";
}

std::string lp(std::optional<double> v, std::optional<double> sigma = std::nullopt) {
  if (!v) return "–";
  std::string s = num(*v, 2);
  if (sigma) s += fmt::format(" <small>± {}</small>", num(*sigma, 2));
  return s;
}

std::string cards(const Comparison& c) {
  const DesignRow& ref = c.reference_row;
  std::string s = "<section class=\"cards\">\n";
  s += fmt::format(
      "<div class=\"card\"><div class=\"k\">Raw CMOS limit ({})</div><div class=\"val\">H {} <small>lp/mm</small>"
      "</div><div class=\"val\">V {} <small>lp/mm</small></div><div class=\"detail\">the bare camera; {}</div></div>\n",
      esc(ref.design), lp(ref.horizontal.value_lp_per_mm(), ref.horizontal.interp_sigma_lp_per_mm),
      lp(ref.vertical.value_lp_per_mm(), ref.vertical.interp_sigma_lp_per_mm),
      ref.horizontal.interp_lp_per_mm && ref.vertical.interp_lp_per_mm ? "interpolated, ± 1σ"
                                                                        : "discrete where no interpolation");
  const bool nyq = c.nyquist_h_lp_per_mm > 0 && c.nyquist_v_lp_per_mm > 0;
  s += fmt::format(
      "<div class=\"card\"><div class=\"k\">Camera sampling (Nyquist) limit</div><div class=\"val\">{}</div>"
      "<div class=\"detail\">at the target plane, from the reference measurement</div></div>\n",
      nyq ? fmt::format("H {} <small>lp/mm</small></div><div class=\"val\">V {} <small>lp/mm</small>",
                        num(c.nyquist_h_lp_per_mm, 2),
                        num(c.nyquist_v_lp_per_mm, 2))
          : std::string("not available"));
  const DesignRow* best = nullptr;
  int failed = 0;
  for (const DesignRow& r : c.designs) {
    if (r.rank && *r.rank == 1 && !best) best = &r;
    if (r.status == RowStatus::failed) ++failed;
  }
  if (best)
    s += fmt::format(
        "<div class=\"card\"><div class=\"k\">Best design</div><div class=\"val\">{} <small>{} lp/mm</small></div>"
        "<div class=\"detail\">mean of H and V{}</div></div>\n",
        esc(best->design), num(*best->mean_hv_lp_per_mm, 2),
        best->mean_pct_of_reference ? fmt::format(", {:.1f} % of raw CMOS", *best->mean_pct_of_reference) : "");
  else
    s += "<div class=\"card\"><div class=\"k\">Best design</div><div class=\"val\">none ranked</div></div>\n";
  s += fmt::format(
      "<div class=\"card\"><div class=\"k\">Designs</div><div class=\"val\">{} <small>compared</small></div>"
      "<div class=\"detail\">{} measurements{}</div></div>\n",
      c.designs.size(), c.measurements.size() + 1, failed ? fmt::format("; {} design(s) failed", failed) : "");
  return s + "</section>\n";
}

}  // namespace

void HtmlReportOptions::validate() const {
  if (thumbnail_max_px < 32 || thumbnail_max_px > 4096)
    throw std::invalid_argument(fmt::format(
        "thumbnail size {} px is out of range: use 32 to 4096 px (the long side of each overlay thumbnail)",
        thumbnail_max_px));
  if (chart_js.empty()) throw std::invalid_argument("the Chart.js path is empty");
}

std::string base64_encode(std::string_view bytes) { return OIIO::Strutil::base64_encode(bytes); }

std::optional<std::string> thumbnail_data_uri(const fs::path& path, int max_px, std::string* why_not) {
  auto no = [&](const std::string& why) {
    if (why_not) *why_not = why;
    return std::nullopt;
  };
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) return no("no overlay: " + path.filename().string() + " is missing");
  auto in = OIIO::ImageInput::open(path.string());
  if (!in) {
    (void)OIIO::geterror();  // clear OIIO's per-thread error
    return no("no overlay: " + path.filename().string() + " cannot be decoded");
  }
  const OIIO::ImageSpec spec = in->spec();
  const int w = spec.width, h = spec.height, nc = spec.nchannels;
  if (w <= 0 || h <= 0 || nc <= 0) return no("no overlay: " + path.filename().string() + " is empty");
  constexpr std::uintmax_t kMaxEmbeddedBytes = 400 * 1024;
  const bool small = std::max(w, h) <= max_px;
  if (small && std::string(in->format_name()) == "png" && fs::file_size(path, ec) <= kMaxEmbeddedBytes && !ec)
    return "data:image/png;base64," + base64_encode(read_file(path));

  std::vector<unsigned char> pixels(size_t(w) * size_t(h) * size_t(nc));
  if (!in->read_image(0, 0, 0, nc, OIIO::TypeDesc::UINT8, pixels.data())) {
    (void)in->geterror();
    return no("no overlay: " + path.filename().string() + " cannot be decoded");
  }
  in->close();
  // To 3-channel RGB: grey is replicated, alpha dropped.
  cv::Mat rgb(h, w, CV_8UC3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const unsigned char* p = &pixels[(size_t(y) * w + x) * nc];
      cv::Vec3b& q = rgb.at<cv::Vec3b>(y, x);
      q = nc >= 3 ? cv::Vec3b(p[0], p[1], p[2]) : cv::Vec3b(p[0], p[0], p[0]);
    }
  if (!small) {
    const double scale = double(max_px) / std::max(w, h);
    cv::Mat out;
    cv::resize(rgb, out, cv::Size(std::max(1, int(std::lround(w * scale))), std::max(1, int(std::lround(h * scale)))),
               0, 0, cv::INTER_AREA);
    rgb = out;
  }
  std::vector<unsigned char> jpeg;
  OIIO::Filesystem::IOVecOutput proxy(jpeg);
  auto writer = OIIO::ImageOutput::create("thumbnail.jpg");
  if (!writer) return no("no overlay: JPEG encoding is not available");
  OIIO::ImageSpec out_spec(rgb.cols, rgb.rows, 3, OIIO::TypeDesc::UINT8);
  out_spec.attribute("Compression", "jpeg:88");
  writer->set_ioproxy(&proxy);
  if (!writer->open("thumbnail.jpg", out_spec) ||
      !writer->write_image(OIIO::TypeDesc::UINT8, rgb.data, 3, int(rgb.step)) || !writer->close()) {
    (void)writer->geterror();
    return no("no overlay: the thumbnail of " + path.filename().string() + " could not be encoded");
  }
  return "data:image/jpeg;base64," +
         base64_encode(std::string_view(reinterpret_cast<const char*>(jpeg.data()), jpeg.size()));
}

std::string render_html_report(const Comparison& c, const HtmlReportOptions& options) {
  options.validate();
  // Read first: a missing Chart.js fails before any thumbnail is encoded.
  const std::string chart_js = read_chart_js(options.chart_js, "the HTML report", "give its path with --chart-js");

  std::set<std::string> versions;
  for (const MeasurementRecord& m : c.measurements)
    if (!m.tactres_version.empty()) versions.insert(m.tactres_version);
  if (!c.reference.tactres_version.empty()) versions.insert(c.reference.tactres_version);
  const std::string measured_with = join(std::vector<std::string>(versions.begin(), versions.end()), ", ");

  // The kind of page (style, data id, charts) first; then this one's content.
  HtmlPage page{.css = kReportCss,
                .data_id = "report-data",
                .chart_script = kReportChartScript,
                .after_script = kReportAfterScript};
  page.title = fmt::format("Design comparison: {} design{} vs raw CMOS ({})", c.designs.size(),
                           c.designs.size() == 1 ? "" : "s", c.reference_row.design);
  page.heading = "Design comparison: resolution limits in lp/mm";
  page.subtitle_html = fmt::format(
      "{} design{} against the bare camera <b>{}</b> (raw CMOS) · criterion m(f) &ge; {} and m &minus; {}σ &gt; 0 · "
      "layout <code>{}</code> · report by tactres {}",
      c.designs.size(), c.designs.size() == 1 ? "" : "s", esc(c.reference_row.design), c.threshold, c.significance_z,
      esc(c.layout), esc(options.tactres_version));
  page.tactres_version = options.tactres_version;
  page.data = page_data(c);

  std::string& s = page.body_html;
  s.reserve(200000);
  s += cards(c);

  s += "<section id=\"table\">\n<h2>Limits per design</h2>\n" + limits_table(c);
  s += "<ul class=\"note\">\n"
       "<li><b>element</b> and <b>discrete</b>: the finest element resolved together with every coarser one (for "
       "repeated presses, the coarsest over the presses); &ge; means every element was resolved, a lower "
       "bound.</li>\n"
       "<li><b>interpolated</b>: where m(f) crosses the criterion between elements. One press: its value ± its "
       "1σ uncertainty. Repeated presses (n &gt; 1): the mean ± the press-to-press sample SD and the mean "
       "uncertainty in quadrature (hover for the SD).</li>\n"
       "<li><b>% of raw CMOS</b>: the interpolated limit (the discrete one where there is none) as a percentage "
       "of the reference's. <b>Mean of H and V</b> ranks the designs; failed designs are shown, never "
       "ranked.</li>\n";
  for (const std::string& n : c.notes) s += "<li>" + esc(n) + "</li>\n";
  for (const DesignRow& r : c.designs)
    for (const std::string& p : r.problems)
      s += fmt::format("<li class=\"status-failed\">{} — failed press {}</li>\n", esc(r.design), esc(p));
  s += "</ul>\n</section>\n";

  s += "<section id=\"bars\">\n<h2>Horizontal and vertical limits per design</h2>\n"
       "<div class=\"chart-box\"><canvas id=\"chart-bars\" role=\"img\" aria-label=\"grouped bar chart of the "
       "limits per design\"></canvas></div>\n"
       "<p class=\"note\">Bars: the limit (interpolated where available) with 1σ error bars and the percentage of "
       "the raw CMOS limit above each bar. Dashed lines: the bare camera's limits; dotted: the camera's sampling "
       "(Nyquist) limit at the target plane.</p>\n</section>\n";

  s += "<section id=\"curves\">\n<h2>Modulation m(f) versus spatial frequency</h2>\n<div class=\"curves\">\n"
       "<div><h3>Horizontal bars</h3><div class=\"chart-box\"><canvas id=\"chart-mtf-h\" role=\"img\" "
       "aria-label=\"m(f) of horizontal bars\"></canvas></div></div>\n"
       "<div><h3>Vertical bars</h3><div class=\"chart-box\"><canvas id=\"chart-mtf-v\" role=\"img\" "
       "aria-label=\"m(f) of vertical bars\"></canvas></div></div>\n</div>\n";
  s += fmt::format(
      "<p class=\"note\">Each press's elements with status ok: m ± 1σ as measured. An element is resolved when m "
      "&ge; {} (red line) and m &minus; {}σ &gt; 0. Repeated presses of a design share its colour; the raw CMOS "
      "curve is black and dashed.</p>\n</section>\n",
      c.threshold, c.significance_z);

  s += "<section id=\"overlays\">\n<h2>Overlays</h2>\n<p class=\"note\" style=\"margin-top:0\">Each capture with "
       "the sampled strips coloured by status (green resolved, orange not resolved, red/grey not measurable). "
       "Click to enlarge.</p>\n";
  s += thumbnails(c, options.thumbnail_max_px);
  s += "</section>\n";

  s += "<section id=\"inputs\">\n<h2>Inputs</h2>\n" + inputs_table(c) + "</section>\n";
  s += fmt::format(
      "<footer>\n<p>Generated by tactres {} from measurements made with tactres {}. This report only aggregates "
      "the measurements (means, spreads, percentages, ranks); every limit, uncertainty and m(f) is as "
      "<code>tactres measure</code> wrote it.</p>\n<p>Charts: Chart.js (MIT licence), inlined; the page needs no "
      "network.</p>\n</footer>\n",
      esc(options.tactres_version), esc(measured_with.empty() ? "an unknown version" : measured_with));
  return render_html_page(page, chart_js);
}

}  // namespace tactres
