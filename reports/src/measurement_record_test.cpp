#include "tactres/reports/measurement_record.h"

#include <doctest/doctest.h>

#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>

#include "test_measurements.h"

namespace tactres {
namespace {

namespace fs = std::filesystem;
using testing::HandMeasurement;
using testing::hand_measurement;

fs::path fixture(const std::string& name) { return fs::path(TACTRES_SOURCE_DIR) / "tests/data/report" / name; }

// The message of the std::invalid_argument that `f` throws ("" if none).
template <typename F>
std::string refusal(F&& f) {
  try {
    f();
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

TEST_CASE("a real measurement JSON (from measure) reads back") {
  const MeasurementRecord r = read_measurement_file(fixture("cmos.json"));
  CHECK(r.design == "cmos");
  CHECK(r.usable);
  CHECK(r.layout == "target/layout.json");
  CHECK(r.threshold == doctest::Approx(0.10));
  CHECK(r.significance_z == doctest::Approx(2.0));
  CHECK(r.horizontal.resolved_any);
  CHECK(r.horizontal.group == 2);
  CHECK(r.horizontal.element == 4);
  CHECK(r.horizontal.lp_per_mm == doctest::Approx(5.656854).epsilon(1e-6));
  REQUIRE(r.horizontal.interpolated_lp_per_mm);
  CHECK(*r.horizontal.interpolated_lp_per_mm == doctest::Approx(6.0731).epsilon(1e-4));
  CHECK(r.nyquist_h_lp_per_mm == doctest::Approx(10.769).epsilon(1e-3));
  CHECK(r.elements.size() == 60);
  CHECK(r.overlay_path() == fixture("cmos.overlay.png"));
}

TEST_CASE("a failed measurement reads back as failed, with its problem") {
  const MeasurementRecord r = read_measurement_file(fixture("T2C4.json"));
  CHECK_FALSE(r.usable);
  CHECK(r.problem.find("no target found") != std::string::npos);
  CHECK_FALSE(r.horizontal.resolved_any);
  CHECK(r.elements.empty());
}

TEST_CASE("malformed measurements are refused naming the file and the field") {
  auto message = [](nlohmann::json j) { return refusal([&] { measurement_from_json(j, "x.json"); }); };
  nlohmann::json good = hand_measurement({});
  CHECK(message(good).empty());

  nlohmann::json j = good;
  j["schema"] = "tactres.target/1";
  CHECK(message(j).find("x.json is not a tactres measurement (schema \"tactres.target/1\"") != std::string::npos);

  j = good;
  j.erase("design");
  CHECK(message(j).find("x.json lacks the required field \"design\"") != std::string::npos);

  j = good;
  j.erase("criterion");
  CHECK(message(j).find("\"criterion\"") != std::string::npos);

  j = good;
  j["criterion"]["threshold"] = 1.5;
  CHECK(message(j).find("x.json.criterion.threshold") != std::string::npos);

  j = good;
  j["limits"]["horizontal_bars"]["group"] = nullptr;
  CHECK(message(j).find("x.json.limits.horizontal_bars says resolved_any = true") != std::string::npos);

  j = good;
  j["limits"]["vertical_bars"]["interpolated_lp_per_mm"] = "6.1";
  CHECK(message(j).find("x.json.limits.vertical_bars.interpolated_lp_per_mm must be a number") !=
        std::string::npos);

  j = good;
  j["usable"] = false;
  j["problem"] = nullptr;
  CHECK(message(j).find("gives no problem") != std::string::npos);

  j = good;
  j["elements"][3]["m"] = nullptr;
  CHECK(message(j).find("x.json.elements[3] has status \"ok\" but m or m_sigma is null") != std::string::npos);

  j = good;
  j["elements"][0]["orientation"] = "diagonal";
  CHECK(message(j).find("x.json.elements[0].orientation") != std::string::npos);

  CHECK(message(nlohmann::json::array()).find("must be a JSON object") != std::string::npos);
}

TEST_CASE("fields reports do not use are ignored: measure may add fields within schema 1") {
  nlohmann::json j = hand_measurement({});
  j["some_future_field"] = {1, 2, 3};
  j["limits"]["horizontal_bars"]["another"] = true;
  CHECK_NOTHROW(measurement_from_json(j, "x.json"));
}

TEST_CASE("unreadable and syntactically broken files are refused naming the path") {
  testing::ReportTempDir dir("reports-record");
  const fs::path missing = dir.path / "missing.json";
  try {
    read_measurement_file(missing);
    FAIL("no error for a missing file");
  } catch (const std::runtime_error& e) {
    CHECK(std::string(e.what()).find(missing.string()) != std::string::npos);
  }
  const fs::path broken = dir.path / "broken.json";
  dir.write("broken.json", "{\"schema\": \"tactres.measurement/1\", ");
  const std::string m = refusal([&] { read_measurement_file(broken); });
  CHECK(m.find(broken.string()) != std::string::npos);
  CHECK(m.find("not valid JSON") != std::string::npos);
}

}  // namespace
}  // namespace tactres
