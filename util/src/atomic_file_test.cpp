#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>
#include <unistd.h>

#include <doctest/doctest.h>

#include "tactres/util/atomic_file.h"

using namespace tactres;
namespace fs = std::filesystem;

namespace {

// A fresh folder of its own, removed at the end.
struct Folder {
  fs::path path = fs::temp_directory_path() / ("tactres_atomic_" + std::to_string(::getpid()));
  Folder() {
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~Folder() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
  size_t entries() const {
    size_t n = 0;
    for (const auto& e : fs::recursive_directory_iterator(path)) n += e.is_regular_file();
    return n;
  }
};

}  // namespace

TEST_CASE("AtomicOutputSet: all outputs appear at commit, in folders made for them") {
  Folder f;
  AtomicOutputSet set;
  set.stage_bytes(f.path / "a.json", "{}\n");
  set.stage(f.path / "sub" / "b.txt", [](const fs::path& temp) { std::ofstream(temp) << "b"; });
  CHECK_FALSE(fs::exists(f.path / "a.json"));  // staged, not yet in place
  set.commit();
  CHECK(read_file(f.path / "a.json") == "{}\n");
  CHECK(read_file(f.path / "sub" / "b.txt") == "b");
  CHECK(f.entries() == 2);  // no temporaries left
}

TEST_CASE("AtomicOutputSet: a failing writer leaves nothing of the set, and names the output") {
  Folder f;
  {
    AtomicOutputSet set;
    set.stage_bytes(f.path / "a.json", "{}\n");
    std::string message;
    try {
      set.stage(f.path / "b.png", [](const fs::path& temp) {
        std::ofstream(temp) << "half";
        throw std::runtime_error("encoder failed");
      });
    } catch (const std::runtime_error& e) {
      message = e.what();
    }
    CHECK(message == "cannot write " + (f.path / "b.png").string() + ": encoder failed");
  }
  CHECK(f.entries() == 0);
}

TEST_CASE("AtomicOutputSet: a rename that fails takes back the ones already made") {
  Folder f;
  fs::create_directories(f.path / "b.json" / "occupied");  // a folder, not empty: no file can replace it
  AtomicOutputSet set;
  set.stage_bytes(f.path / "a.json", "a");
  set.stage_bytes(f.path / "b.json.tmp-target", "b");  // staged fine
  set.stage_bytes(f.path / "b.json", "b");             // its rename will fail
  CHECK_THROWS_AS(set.commit(), std::runtime_error);
  CHECK_FALSE(fs::exists(f.path / "a.json"));
  CHECK_FALSE(fs::exists(f.path / "b.json.tmp-target"));
  CHECK(fs::is_directory(f.path / "b.json"));
}

TEST_CASE("AtomicOutputSet: a failed set leaves the earlier results as they were, a good one replaces them") {
  Folder f;
  write_file_atomically(f.path / "r.json", "old json");
  write_file_atomically(f.path / "r.csv", "old csv");
  fs::create_directories(f.path / "ov.png" / "occupied");  // the overlay's rename will fail
  {
    AtomicOutputSet set;
    set.stage_bytes(f.path / "r.json", "new json");
    set.stage_bytes(f.path / "r.csv", "new csv");
    set.stage_bytes(f.path / "ov.png", "png");
    CHECK_THROWS_AS(set.commit(), std::runtime_error);
  }
  CHECK(read_file(f.path / "r.json") == "old json");
  CHECK(read_file(f.path / "r.csv") == "old csv");
  fs::remove_all(f.path / "ov.png");
  AtomicOutputSet set;
  set.stage_bytes(f.path / "r.json", "new json");
  set.stage_bytes(f.path / "r.csv", "new csv");
  set.commit();
  CHECK(read_file(f.path / "r.json") == "new json");
  CHECK(read_file(f.path / "r.csv") == "new csv");
  CHECK(f.entries() == 2);  // no temporaries, nothing moved aside left
  set.commit();             // empty after a commit: nothing happens
  CHECK(read_file(f.path / "r.json") == "new json");
}

TEST_CASE("AtomicOutputSet: a staged removal goes at commit, and stays when the commit fails") {
  Folder f;
  write_file_atomically(f.path / "r.json", "old json");
  write_file_atomically(f.path / "r.csv", "old csv");
  fs::create_directories(f.path / "ov.png" / "occupied");  // a folder: neither a file to remove nor to replace
  {
    AtomicOutputSet set;
    set.stage_bytes(f.path / "r.json", "failed json");
    set.stage_removal(f.path / "r.csv");
    set.stage_bytes(f.path / "ov.png", "png");  // its rename fails
    CHECK_THROWS_AS(set.commit(), std::runtime_error);
  }
  CHECK(read_file(f.path / "r.json") == "old json");
  CHECK(read_file(f.path / "r.csv") == "old csv");
  fs::remove_all(f.path / "ov.png");
  AtomicOutputSet set;
  set.stage_bytes(f.path / "r.json", "failed json");
  set.stage_removal(f.path / "r.csv");
  set.stage_removal(f.path / "never-written.png");  // nothing there: nothing to do
  set.commit();
  CHECK(read_file(f.path / "r.json") == "failed json");
  CHECK_FALSE(fs::exists(f.path / "r.csv"));
  CHECK(f.entries() == 1);
}

TEST_CASE("write_file_atomically: a name as long as the file system allows is written, and the temporary goes") {
  Folder f;
  // 255 bytes in all, with two-byte characters where the stem is cut.
  std::string stem;
  while (stem.size() + 2 <= 250) stem += "\xc3\xa9";  // U+00E9
  stem.resize(250, 'x');
  const fs::path path = f.path / (stem + ".json");
  REQUIRE(path.filename().string().size() == 255);
  write_file_atomically(path, "{}\n");
  CHECK(fs::exists(path));
  CHECK(f.entries() == 1);
  // One byte more is the system's limit, and the message says to shorten it.
  try {
    write_file_atomically(f.path / (stem + "y.json"), "{}\n");
    FAIL("a 256-byte name was written");
  } catch (const std::runtime_error& e) {
    CHECK(std::string(e.what()).find("shorten the name") != std::string::npos);
  }
  CHECK(f.entries() == 1);
}

TEST_CASE("file_sha1: the SHA-1 of the bytes, lower-case hex") {
  Folder f;
  write_file_atomically(f.path / "abc.txt", "abc");
  CHECK(file_sha1(f.path / "abc.txt") == "a9993e364706816aba3e25717850c26c9cd0d89d");
}

TEST_CASE("refuse_colliding_outputs: an output over an input or another output is refused, by any path to it") {
  Folder f;
  const fs::path capture = f.path / "capture.png";
  std::ofstream(capture) << "pixels";
  fs::create_symlink(capture, f.path / "link.png");
  const fs::path cwd = fs::current_path();
  fs::current_path(f.path);
  const auto refused = [](const std::vector<fs::path>& out, const std::vector<fs::path>& in, const char* says) {
    try {
      refuse_colliding_outputs(out, in);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what()).find(says) != std::string::npos;
    }
    return false;
  };
  CHECK(refused({"x.json", "capture.png"}, {"capture.png"}, "is also an input"));
  CHECK(refused({"./sub/../capture.png"}, {capture}, "is also an input"));
  CHECK(refused({"link.png"}, {"capture.png"}, "is also an input"));  // a link to it
  CHECK(refused({"x.json", "./x.json"}, {}, "two outputs go to"));     // neither exists yet
  CHECK_NOTHROW(refuse_colliding_outputs({"x.json", "x.csv", "", ""}, {"capture.png", ""}));
  fs::current_path(cwd);
}
