#include "tactres/util/json_fields.h"

#include <string>

#include <doctest/doctest.h>

using namespace tactres;

TEST_CASE("json_text: bytes that are not UTF-8 become U+FFFD instead of an exception") {
  const std::string latin1_name = "caf\xe9 raw";  // a Latin-1 file name
  nlohmann::json j;
  j["design"] = latin1_name;
  CHECK_THROWS(j.dump());  // what tactres used to write with
  const std::string text = json_text(j);
  CHECK(nlohmann::json::parse(text)["design"] == "caf\xEF\xBF\xBD raw");
  CHECK(text.find('\n') != std::string::npos);  // indented by default
  CHECK(json_text(j, -1).find('\n') == std::string::npos);
}

TEST_CASE("valid_utf8: valid text passes unchanged, each broken sequence becomes U+FFFD") {
  CHECK(valid_utf8("G2E5 \xC2\xB1 0.13") == "G2E5 \xC2\xB1 0.13");  // a real plus-minus
  CHECK(valid_utf8("a\xff" "b") == "a\xEF\xBF\xBD" "b");
  CHECK(valid_utf8("\xC3") == "\xEF\xBF\xBD");  // cut in the middle of a character
  CHECK(valid_utf8("") == "");
}
