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
            // On a log axis (CNR) a lower end at or below 0 has no pixel: the bar runs off the bottom.
            var top = y.getPixelForValue(v + s);
            var bottom = y.type === 'logarithmic' && v - s <= 0 ? area.bottom : y.getPixelForValue(v - s);
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
                (o.pct === null ? '' : ' (' + fmt(o.pct, 1) + '% of raw CMOS)') + (o.interpolated ? '' : ', discrete') +
                (o.limited_by ? ', limited by ' + o.limited_by : '');
            } } }
          }
        }
      });
    })();

    // Frequency axis shared by the m(f) and CNR(f) charts: log scale, round ticks.
    function frequencyAxis(fmin, fmax) {
      return { type: 'logarithmic', min: fmin / 1.12, max: fmax * 1.12,
               title: { display: true, text: 'spatial frequency (lp/mm, log scale)' },
               ticks: { autoSkip: false, callback: function (v) {
                 var r = Math.round(v * 1000) / 1000;
                 return [0.5, 1, 2, 3, 5, 10, 20, 30, 50, 100, 200].indexOf(r) >= 0 ? String(r) : '';
               } } };
    }

    // One dataset per usable press, one colour per design; spec.value(p) and
    // spec.sigma(p) read a point's value and 1-sigma, spec.keep(p) filters.
    function pressDatasets(key, spec) {
      var datasets = [];
      data.curves.forEach(function (c) {
        var pts = c[key].filter(spec.keep);
        if (!pts.length) return;
        var colour = c.reference ? '#111111' : colourOf[c.design];
        datasets.push({
          label: c.reference ? c.design + ' (raw CMOS)' : c.design,
          data: pts.map(function (p) { return { x: p.f, y: spec.value(p) }; }),
          points: pts, file: c.file,
          errorBars: pts.map(spec.sigma), errorBarColor: colour, errorBarWidth: 1,
          borderColor: colour, backgroundColor: colour, showLine: true, tension: 0,
          borderWidth: c.reference ? 2.4 : 1.5, borderDash: c.reference ? [6, 3] : [],
          pointRadius: 2.2, pointHoverRadius: 4, hideInLegend: !c.first_of_design, order: c.reference ? 0 : 1
        });
      });
      return datasets;
    }

    // 2-5. Per press and orientation: m(f) with the criterion line, and
    // beside it (measurement/2) CNR(f) on a log axis with the Rose k line.
    function curveChart(id, key, spec) {
      var canvas = document.getElementById(id);
      if (!canvas) return;  // e.g. no CNR charts for measurement/1 inputs
      var datasets = pressDatasets(key, spec), fmin = Infinity, fmax = 0;
      datasets.forEach(function (d) {
        d.points.forEach(function (p) { fmin = Math.min(fmin, p.f); fmax = Math.max(fmax, p.f); });
      });
      if (!datasets.length) { fmin = 1; fmax = 10; }
      var n = key === 'h' ? nyq.h : nyq.v;
      var lines = spec.lines.slice();
      if (n > 0) lines.push({ x: n, color: '#6b7280', dash: [2, 3], label: 'Nyquist ' + fmt(n, 2) });
      new Chart(canvas, {
        type: 'scatter',
        data: { datasets: datasets },
        plugins: [errorBars, refLines],
        options: {
          scales: { x: frequencyAxis(fmin, Math.max(fmax, n || 0)), y: spec.yAxis(datasets) },
          plugins: {
            legend: { position: 'top', labels: { boxWidth: 14, filter: function (item, d) {
              return !d.datasets[item.datasetIndex].hideInLegend; } } },
            refLines: { lines: lines },
            tooltip: { callbacks: { label: function (c) {
              var p = c.dataset.points[c.dataIndex];
              return c.dataset.label + ': G' + p.g + 'E' + p.e + ' ' + fmt(p.f, 2) + ' lp/mm, ' + spec.text(p);
            } } }
          }
        }
      });
    }

    var mSpec = {
      keep: function () { return true; },
      value: function (p) { return p.m; }, sigma: function (p) { return p.s; },
      lines: [{ y: data.threshold, color: '#b3261e', dash: [6, 4], align: 'left', label: 'criterion m = ' + data.threshold }],
      yAxis: function (datasets) {
        var mmin = 0;
        datasets.forEach(function (d) { d.points.forEach(function (p) { mmin = Math.min(mmin, p.m - p.s); }); });
        return { min: Math.min(0, Math.floor(mmin * 10) / 10), max: 1.05, title: { display: true, text: 'modulation m(f)' } };
      },
      text: function (p) { return 'm = ' + fmt(p.m, 3) + ' ± ' + fmt(p.s, 3); }
    };

    // CNR spans decades (a bright coarse element ~1000, a fine one ~1): a
    // log axis in whole decades, the k line inside it. A CNR under a
    // hundredth of k (or 0) would stretch the axis over empty decades and
    // is left out (its element is undetectable anyway).
    var k = data.detectability_k;
    var cnrFloor = (k || 1) / 100;
    var cnrSpec = {
      keep: function (p) { return p.c !== null && p.c >= cnrFloor; },
      value: function (p) { return p.c; }, sigma: function (p) { return p.cs; },
      lines: k ? [{ y: k, color: '#b3261e', dash: [6, 4], align: 'left', label: 'Rose threshold k = ' + k }] : [],
      yAxis: function (datasets) {
        var lo = k || 1, hi = k || 1;
        datasets.forEach(function (d) { d.points.forEach(function (p) { lo = Math.min(lo, p.c); hi = Math.max(hi, p.c); }); });
        return { type: 'logarithmic',
                 min: Math.pow(10, Math.floor(Math.log10(lo / 1.5))), max: Math.pow(10, Math.ceil(Math.log10(hi * 1.5))),
                 title: { display: true, text: 'contrast-to-noise ratio CNR (log scale)' },
                 // Full grid lines only at the labelled 1-3-10 ticks: nine per decade read as graph paper.
                 grid: { color: function (c) { return c.tick && c.tick.label ? 'rgba(0,0,0,0.12)' : 'rgba(0,0,0,0.035)'; } },
                 ticks: { autoSkip: false, callback: function (v) {
                   var e = Math.log10(v), m = v / Math.pow(10, Math.floor(e + 1e-9));
                   return [1, 3].some(function (x) { return Math.abs(m - x) < 1e-6; }) ? String(+v.toPrecision(3)) : '';
                 } } };
      },
      text: function (p) { return 'CNR = ' + fmt(p.c, 1) + (p.cs !== null ? ' ± ' + fmt(p.cs, 1) : ''); }
    };

    curveChart('chart-mtf-h', 'h', mSpec);
    curveChart('chart-mtf-v', 'v', mSpec);
    curveChart('chart-cnr-h', 'h', cnrSpec);
    curveChart('chart-cnr-v', 'v', cnrSpec);

    // Charts follow the page size when printing, and back.
    ['beforeprint', 'afterprint'].forEach(function (ev) {
      window.addEventListener(ev, function () {
        Object.values(Chart.instances).forEach(function (c) { c.resize(); });
      });
    });
