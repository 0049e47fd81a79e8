#include <doctest/doctest.h>

#include <algorithm>

#include "tactres/live/live_csv.h"

using namespace tactres;

namespace {
size_t cells(const std::string& line) { return std::count(line.begin(), line.end(), ',') + 1; }
}  // namespace

TEST_CASE("live CSV: every row has the header's cells, on one line, with no NaN") {
  const std::string header = live_csv_header();
  LiveFrameResult bad;
  bad.index = 3;
  bad.name = "frame_03.png";
  bad.problem = "cannot decode: read error\nPNG library error";
  const std::string row = live_csv_row(bad, {}, {});
  CHECK(std::count(row.begin(), row.end(), '\n') == 1);  // the message's line break flattened
  CHECK(row.find("unusable") != std::string::npos);
  CHECK(row.find("read error; PNG") != std::string::npos);

  LiveFrameResult ok;
  ok.measured = true;
  ok.tracked = true;
  Limit& h = ok.measurement.horizontal_parts.optical;
  h.any_resolved = true;
  h.group = 2;
  h.element = 4;
  h.lp_per_mm = 5.657;
  h.interpolated_lp_per_mm = std::numeric_limits<double>::quiet_NaN();  // never printed
  FocusReading f;
  f.present = true;
  f.group = 2;
  f.element = 4;
  f.m = 0.25;
  f.m_sigma = 0.01;
  const std::string good = live_csv_row(ok, f, {});
  CHECK(good.find("nan") == std::string::npos);
  CHECK(good.find(",ok,1,0,") != std::string::npos);
  CHECK(good.find("2,4,5.657000,,") != std::string::npos);
  // The unquoted cells before `problem` match the header's count.
  CHECK(cells(good) == cells(header));
  CHECK(cells(row) == cells(header));
}
