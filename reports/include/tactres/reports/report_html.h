#pragma once
// The comparison as ONE self-contained HTML file that opens offline: inline
// CSS, Chart.js inlined from Debian's libjs-chart.js, the data as inline
// JSON, and overlay thumbnails as data URIs. No network, no other file.
// The page machinery (stylesheet, script prologue, markers on <body>) is
// html_page.h's, shared with bench.html. docs/REPORT.md describes what it
// shows.

#include <filesystem>
#include <optional>
#include <string>
#include <string_view>

#include "tactres/reports/comparison.h"
#include "tactres/reports/html_page.h"

namespace tactres {

struct HtmlReportOptions {
  std::filesystem::path chart_js = kDebianChartJsPath;  // read at report time and inlined
  int thumbnail_max_px = 640;   // overlays larger than this (long side) are downscaled
  std::string tactres_version;  // of the report generator, shown in the page

  void validate() const;  // throws std::invalid_argument
};

// Renders the page. Throws std::runtime_error naming the path when Chart.js
// cannot be read (with how to install it). A missing or unreadable overlay
// is not an error: its thumbnail says so.
std::string render_html_report(const Comparison& c, const HtmlReportOptions& options);

// Standard base64 (RFC 4648, with padding), for data URIs.
std::string base64_encode(std::string_view bytes);

// A data URI of the image at `path`, downscaled (area averaging) so that its
// long side is at most max_px: the original bytes as image/png when the file
// is a PNG small enough in pixels and bytes, else a JPEG. Returns nullopt and
// sets `why_not` when the file is missing or cannot be decoded.
std::optional<std::string> thumbnail_data_uri(const std::filesystem::path& path, int max_px, std::string* why_not);

}  // namespace tactres
