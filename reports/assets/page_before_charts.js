(function () {
  'use strict';
  var body = document.body;
  function fail(e) {
    var msg = String((e && e.message) || e);
    body.setAttribute('data-script-error', msg);
    var box = document.getElementById('script-error');
    if (box) { box.hidden = false; box.textContent = 'The charts could not be drawn: ' + msg; }
  }
  try {
    if (typeof Chart === 'undefined') throw new Error('Chart.js is missing from this file');
    var data = JSON.parse(document.getElementById('{data_id}').textContent);
    Chart.defaults.font.family = getComputedStyle(body).fontFamily;
    Chart.defaults.font.size = 12;
    Chart.defaults.color = '#333';
    Chart.defaults.animation = false;
    Chart.defaults.maintainAspectRatio = false;

    var rendered = 0;
    Chart.register({
      id: 'renderedCounter',
      afterRender: function (chart) {
        if (chart.$tactresCounted || !(chart.width > 0 && chart.height > 0)) return;
        chart.$tactresCounted = true;
        chart.canvas.setAttribute('data-rendered-size', chart.width + 'x' + chart.height);
        body.setAttribute('data-charts-rendered', String(++rendered));
      }
    });

    // A Chart.js plugin that writes dataset[id][i], where there is one, in
    // the dataset's colour at place(chart, dataset, meta, element, i): an
    // [x, y] in pixels, or null for none.
    function textLabels(id, font, align, baseline, place) {
      return {
        id: id,
        afterDatasetsDraw: function (chart) {
          var ctx = chart.ctx;
          ctx.save();
          ctx.font = font + ' ' + Chart.defaults.font.family;
          ctx.textAlign = align;
          ctx.textBaseline = baseline;
          chart.data.datasets.forEach(function (ds, di) {
            if (!ds[id] || !chart.isDatasetVisible(di)) return;
            var meta = chart.getDatasetMeta(di);
            meta.data.forEach(function (el, i) {
              var at = ds[id][i] ? place(chart, ds, meta, el, i) : null;
              if (!at) return;
              ctx.fillStyle = ds.borderColor;
              ctx.fillText(ds[id][i], at[0], at[1]);
            });
          });
          ctx.restore();
        }
      };
    }
