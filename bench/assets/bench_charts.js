    // dataset.pointLabels[i]: text beside point i.
    var pointLabels = textLabels('pointLabels', '11px', 'start', 'middle', function (chart, ds, meta, el) {
      return [el.x + 8, el.y - 8];
    });

    var colours = {preset: '#1d2330', bin_px: '#0072b2', fit_psf_shape: '#d55e00',
                   pose_boundary_points: '#009e73', supersampling: '#cc79a7'};
    var analysis = data.settings.filter(function (s) { return s.sweep !== 'supersampling'; });
    var measured = analysis.filter(function (s) { return s.median_error_pct !== null; });
    var sweeps = [];
    measured.forEach(function (s) { if (sweeps.indexOf(s.sweep) < 0) sweeps.push(s.sweep); });
    var yMax = Math.max.apply(null, measured.map(function (s) { return s.median_error_pct; }).concat([0.1])) * 1.15;
    var datasets = sweeps.map(function (sw) {
      var pts = measured.filter(function (s) { return s.sweep === sw; });
      return {
        label: sw === 'preset' ? 'presets' : 'balanced, ' + sw + ' varied',
        data: pts.map(function (s) { return {x: s.ms_median, y: s.median_error_pct, s: s}; }),
        // Presets and front points are named; the rest on hover (they crowd).
        pointLabels: pts.map(function (s) { return s.sweep === 'preset' || s.pareto ? s.label : ''; }),
        backgroundColor: colours[sw] || '#7f7f7f', borderColor: colours[sw] || '#7f7f7f',
        pointRadius: sw === 'preset' ? 7 : 5, pointStyle: sw === 'preset' ? 'rectRot' : 'circle',
        showLine: false
      };
    });
    var front = measured.filter(function (s) { return s.pareto; })
                        .sort(function (a, b) { return a.ms_median - b.ms_median; });
    datasets.push({
      label: 'Pareto front', data: front.map(function (s) { return {x: s.ms_median, y: s.median_error_pct, s: s}; }),
      showLine: true, borderColor: '#b3261e', backgroundColor: 'rgba(0,0,0,0)', borderWidth: 2,
      pointRadius: 11, pointBorderWidth: 2, pointStyle: 'circle', stepped: false
    });
    if (data.decode_ms_median > 0)
      datasets.push({
        label: 'decode floor (load_image)', data: [{x: data.decode_ms_median, y: 0}, {x: data.decode_ms_median, y: yMax}],
        showLine: true, borderColor: '#5b6472', borderDash: [6, 4], borderWidth: 1.5, pointRadius: 0
      });
    new Chart(document.getElementById('chart-pareto'), {
      type: 'scatter',
      data: {datasets: datasets},
      options: {
        scales: {
          x: {min: 0, title: {display: true, text: 'analysis time per capture: median thread CPU time (ms, single-threaded)'}},
          y: {min: 0, max: yMax, title: {display: true, text: 'median |error| of the interpolated limit (%)'}}
        },
        plugins: {
          tooltip: {callbacks: {label: function (ctx) {
            var s = ctx.raw.s;
            if (!s) return 'decode floor: ' + data.decode_ms_median.toFixed(1) + ' ms';
            return s.setting + ': ' + s.ms_median.toFixed(1) + ' ms, median |e| ' + s.median_error_pct.toFixed(2) +
                   ' %, p95 ' + s.p95_error_pct.toFixed(2) + ' %';
          }}}
        }
      },
      plugins: [pointLabels]
    });

    // Where the time goes: decode, then the analysis stages, per setting.
    var stages = [['decode (load_image)', 'decode_ms', '#bdbdbd'], ['locate fiducials', 'locate_fiducials_ms', '#0072b2'],
                  ['pose', 'pose_ms', '#56b4e9'], ['reference patch', 'reference_patch_ms', '#009e73'],
                  ['profiles', 'profiles_ms', '#e69f00'], ['fits', 'fits_ms', '#d55e00'],
                  ['decide', 'decide_ms', '#cc79a7'], ['other', 'other_ms', '#7f7f7f']];
    var timed = analysis.filter(function (s) { return s.usable_captures > 0; });
    new Chart(document.getElementById('chart-stages'), {
      type: 'bar',
      data: {
        labels: timed.map(function (s) { return s.setting; }),
        datasets: stages.map(function (st) {
          return {label: st[0], backgroundColor: st[2],
                  data: timed.map(function (s) { return st[1] === 'decode_ms' ? data.decode_wall_ms_median : s.stages[st[1]]; })};
        })
      },
      options: {
        indexAxis: 'y',
        scales: {x: {stacked: true, title: {display: true, text: 'median wall-clock ms per capture'}}, y: {stacked: true}}
      }
    });

    // The simulator: error versus supersampling, with its render time.
    var ss = data.settings.filter(function (s) { return s.sweep === 'supersampling'; });
    new Chart(document.getElementById('chart-supersampling'), {
      type: 'bar',
      data: {
        labels: ss.map(function (s) { return s.label; }),
        datasets: [
          {label: 'median |error| (%)', data: ss.map(function (s) { return s.median_error_pct; }),
           backgroundColor: '#cc79a7', yAxisID: 'y'},
          {label: 'p95 |error| (%)', data: ss.map(function (s) { return s.p95_error_pct; }),
           backgroundColor: '#e7b7d3', yAxisID: 'y'},
          {label: 'render time (ms)', type: 'line', data: ss.map(function (s) { return s.render_ms_median; }),
           borderColor: '#1d2330', backgroundColor: '#1d2330', yAxisID: 'y2'}
        ]
      },
      options: {
        scales: {
          y: {min: 0, position: 'left', title: {display: true, text: '|error| of the interpolated limit (%)'}},
          y2: {min: 0, position: 'right', grid: {drawOnChartArea: false}, title: {display: true, text: 'render ms'}}
        }
      }
    });
