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
