#include "tactres/reports/report_csv.h"

#include <doctest/doctest.h>

#include <sstream>
#include <string>
#include <vector>

#include "test_measurements.h"

namespace tactres {
namespace {

using testing::HandMeasurement;
using testing::hand_measurement;

HandMeasurement make(const std::string& design, std::optional<double> h, std::optional<double> v) {
  HandMeasurement m;
  m.design = design;
  m.h.interp = h;
  m.h.sigma = h ? std::optional<double>(0.1) : std::nullopt;
  m.v.interp = v;
  m.v.sigma = v ? std::optional<double>(0.1) : std::nullopt;
  return m;
}

MeasurementRecord record(const HandMeasurement& m, const std::string& file) {
  return measurement_from_json(hand_measurement(m), file);
}

// Splits one CSV line (quoted cells may hold commas and doubled quotes).
std::vector<std::string> cells(const std::string& line) {
  std::vector<std::string> out(1);
  bool quoted = false;
  for (size_t i = 0; i < line.size(); ++i) {
    const char ch = line[i];
    if (quoted) {
      if (ch == '"' && i + 1 < line.size() && line[i + 1] == '"') out.back() += '"', ++i;
      else if (ch == '"') quoted = false;
      else out.back() += ch;
    } else if (ch == '"') {
      quoted = true;
    } else if (ch == ',') {
      out.emplace_back();
    } else {
      out.back() += ch;
    }
  }
  return out;
}

std::vector<std::string> lines(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  for (std::string l; std::getline(in, l);) out.push_back(l);
  return out;
}

// The cell of column `name` in `row`, by the header's position.
std::string column(const std::vector<std::string>& header, const std::vector<std::string>& row, const std::string& name) {
  for (size_t i = 0; i < header.size(); ++i)
    if (header[i] == name) return row.at(i);
  FAIL("no column " << name);
  return std::string();
}

TEST_CASE("the CSV header is the documented, stable column list") {
  CHECK(report_csv_header() ==
        "role,design,n,n_failed,status,"
        "h_group,h_element,h_lp_per_mm,h_beyond_finest,h_interp_lp_per_mm,h_interp_sd_lp_per_mm,"
        "h_interp_sigma_lp_per_mm,h_pct_of_reference,"
        "v_group,v_element,v_lp_per_mm,v_beyond_finest,v_interp_lp_per_mm,v_interp_sd_lp_per_mm,"
        "v_interp_sigma_lp_per_mm,v_pct_of_reference,"
        "sigma_basis,mean_hv_lp_per_mm,mean_pct_of_reference,rank,nyquist_h_lp_per_mm,nyquist_v_lp_per_mm,"
        "threshold,problem,files,"
        // The two limits (measurement/2), appended so that old column positions hold.
        "h_limited_by,h_optical_lp_per_mm,h_optical_sigma_lp_per_mm,h_optical_beyond_finest,"
        "h_optical_pct_of_reference,h_detectability_lp_per_mm,h_detectability_sigma_lp_per_mm,"
        "h_detectability_beyond_finest,h_detectability_pct_of_reference,h_light_needed_factor,"
        "v_limited_by,v_optical_lp_per_mm,v_optical_sigma_lp_per_mm,v_optical_beyond_finest,"
        "v_optical_pct_of_reference,v_detectability_lp_per_mm,v_detectability_sigma_lp_per_mm,"
        "v_detectability_beyond_finest,v_detectability_pct_of_reference,v_light_needed_factor,"
        "light_needed_factor,detectability_k\n");
}

TEST_CASE("CSV rows: the reference first, then each design, failed rows keep their problem") {
  HandMeasurement ref = make("cmos", 8.0, 10.0);
  ref.h.group = 3;
  ref.h.element = 1;
  ref.h.lp_per_mm = 8.0;
  HandMeasurement failed = make("F, \"quoted\"", std::nullopt, std::nullopt);
  failed.usable = false;
  failed.problem = "no target found, refocus";
  const Comparison c =
      compare_designs({record(make("T1", 6.0, 5.0), "t1a.json"), record(make("T1", 6.2, 5.0), "t1b.json"),
                       record(failed, "f.json")},
                      record(ref, "cmos.json"));
  const std::vector<std::string> l = lines(report_csv(c));
  REQUIRE(l.size() == 4);
  const std::vector<std::string> header = cells(l[0]);
  auto col = [&](const std::vector<std::string>& row, const std::string& name) {
    for (size_t i = 0; i < header.size(); ++i)
      if (header[i] == name) return row.at(i);
    FAIL("no column " << name);
    return std::string();
  };
  for (size_t i = 1; i < l.size(); ++i) CHECK(cells(l[i]).size() == header.size());

  const auto r = cells(l[1]);
  CHECK(col(r, "role") == "reference");
  CHECK(col(r, "design") == "cmos");
  CHECK(col(r, "status") == "reference");
  CHECK(col(r, "h_group") == "3");
  CHECK(col(r, "h_lp_per_mm") == "8.0000");
  CHECK(col(r, "h_interp_lp_per_mm") == "8.0000");
  CHECK(col(r, "h_pct_of_reference") == "100.00");
  CHECK(col(r, "mean_hv_lp_per_mm") == "9.0000");
  CHECK(col(r, "rank").empty());
  CHECK(col(r, "nyquist_h_lp_per_mm") == "10.0000");
  CHECK(col(r, "threshold") == "0.1");
  CHECK(col(r, "files") == "cmos.json");

  const auto t = cells(l[2]);
  CHECK(col(t, "role") == "design");
  CHECK(col(t, "n") == "2");
  CHECK(col(t, "status") == "ok");
  CHECK(col(t, "h_interp_lp_per_mm") == "6.1000");
  CHECK(col(t, "h_interp_sd_lp_per_mm") == "0.1414");  // sample SD of 6.0 and 6.2
  CHECK(col(t, "sigma_basis") == "spread_and_mean_sigma");
  CHECK(col(t, "h_pct_of_reference") == "76.25");      // 6.1 / 8
  CHECK(col(t, "v_pct_of_reference") == "50.00");
  CHECK(col(t, "mean_pct_of_reference") == "61.67");   // 5.55 / 9
  CHECK(col(t, "rank") == "1");
  CHECK(col(t, "nyquist_h_lp_per_mm").empty());
  CHECK(col(t, "files") == "t1a.json;t1b.json");

  const auto f = cells(l[3]);
  CHECK(col(f, "design") == "F, \"quoted\"");
  CHECK(col(f, "status") == "failed");
  CHECK(col(f, "n") == "0");
  CHECK(col(f, "n_failed") == "1");
  CHECK(col(f, "h_lp_per_mm").empty());
  CHECK(col(f, "rank").empty());
  CHECK(col(f, "problem") == "f.json: no target found, refocus");
}

TEST_CASE("CSV: the two limits, the limiting factor and the light needed, appended to each row") {
  HandMeasurement ref = make("cmos", 8.0, 10.0), a = make("A", 6.0, 6.0), l = make("L", 4.0, 5.0);
  ref.schema = a.schema = l.schema = 2;
  testing::limit_by_light(l.h, 7.0, 1.8, l.h_parts);
  testing::limit_by_light(l.v, 9.0, 1.2, l.v_parts);
  const Comparison c = compare_designs({record(a, "a.json"), record(l, "l.json")}, record(ref, "cmos.json"));
  const std::vector<std::string> text = lines(report_csv(c));
  REQUIRE(text.size() == 4);
  const std::vector<std::string> header = cells(text[0]);
  for (size_t i = 1; i < text.size(); ++i) CHECK(cells(text[i]).size() == header.size());
  // The old columns keep their positions: the new ones come after "files".
  CHECK(header.at(29) == "files");
  CHECK(header.at(30) == "h_limited_by");

  const auto r = cells(text[1]), da = cells(text[2]), dl = cells(text[3]);
  auto col = [&](const std::vector<std::string>& row, const std::string& name) { return column(header, row, name); };
  CHECK(col(dl, "h_limited_by") == "light/noise");
  CHECK(col(dl, "h_optical_lp_per_mm") == "7.0000");
  CHECK(col(dl, "h_optical_pct_of_reference") == "87.50");
  CHECK(col(dl, "h_detectability_lp_per_mm") == "4.0000");
  CHECK(col(dl, "h_detectability_pct_of_reference") == "50.00");
  CHECK(col(dl, "h_detectability_beyond_finest") == "false");
  CHECK(col(dl, "h_pct_of_reference") == "50.00");  // the reported one: the detectability limit
  CHECK(col(dl, "h_light_needed_factor") == "1.8");
  CHECK(col(dl, "v_light_needed_factor") == "1.2");
  CHECK(col(dl, "light_needed_factor") == "1.8");
  CHECK(col(dl, "rank") == "2");  // mean 4.5 against A's 6: ranked by the reported limits
  CHECK(col(da, "rank") == "1");
  CHECK(col(da, "v_limited_by") == "optics");
  CHECK(col(da, "v_detectability_lp_per_mm") == "8.0000");  // every element detectable: the finest,
  CHECK(col(da, "v_detectability_beyond_finest") == "true");  // a lower bound
  CHECK(col(da, "v_detectability_sigma_lp_per_mm").empty());
  CHECK(col(da, "light_needed_factor") == "0.25");
  CHECK(col(r, "h_limited_by") == "optics");
  CHECK(col(r, "h_optical_pct_of_reference") == "100.00");
  CHECK(col(r, "detectability_k") == "5");
}

TEST_CASE("CSV: a measurement/1 file still reports, its detectability columns empty") {
  const Comparison c = compare_designs({record(make("A", 6.0, 5.0), "a.json")}, record(make("cmos", 8.0, 10.0), "cmos.json"));
  const std::vector<std::string> text = lines(report_csv(c));
  REQUIRE(text.size() == 3);
  const std::vector<std::string> header = cells(text[0]);
  const auto a = cells(text[2]);
  REQUIRE(a.size() == header.size());
  auto col = [&](const std::string& name) { return column(header, a, name); };
  CHECK(col("h_pct_of_reference") == "75.00");
  CHECK(col("h_optical_lp_per_mm") == "6.0000");  // the reported limit is the optical one
  CHECK(col("h_optical_pct_of_reference") == "75.00");
  CHECK(col("h_limited_by").empty());
  CHECK(col("h_detectability_lp_per_mm").empty());
  CHECK(col("h_detectability_pct_of_reference").empty());
  CHECK(col("light_needed_factor").empty());
  CHECK(col("detectability_k").empty());
  CHECK(col("rank") == "1");
}

}  // namespace
}  // namespace tactres
