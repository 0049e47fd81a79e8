#pragma once
// The bench as one self-contained HTML page (bench.html): accuracy versus
// time per setting with the Pareto front and the decode floor, where the
// time goes by stage, the simulator's supersampling sweep, and the summary
// table. Built on the page machinery it shares with the report
// (html_page.h): the same stylesheet, Chart.js source and options
// (HtmlReportOptions: Debian's libjs-chart.js, inlined so the page opens
// offline), escaping, and data-charts-expected / data-charts-rendered
// markers on <body>.

#include <string>

#include "tactres/bench/bench.h"
#include "tactres/reports/report_html.h"

namespace tactres {

// Throws std::runtime_error naming the path when Chart.js cannot be read.
std::string render_bench_html(const BenchResult& result, const HtmlReportOptions& options);

}  // namespace tactres
