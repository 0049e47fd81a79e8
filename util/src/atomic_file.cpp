#include "tactres/util/atomic_file.h"

#include <fstream>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <system_error>

namespace tactres {
namespace {

std::string random_tag() {
  static thread_local std::mt19937_64 rng{std::random_device{}()};
  static constexpr char kHex[] = "0123456789abcdef";
  std::string tag(8, '0');
  for (char& c : tag) c = kHex[rng() % 16];
  return tag;
}

}  // namespace

AtomicOutput::AtomicOutput(std::filesystem::path final_path) : final_path_(std::move(final_path)) {
  // ".name.tmp-XXXXXXXX.ext": hidden, unique, and with the real extension last.
  const auto dir = final_path_.parent_path();
  std::string name = ".";  // appended piecewise: GCC 12 warns falsely on a chain of +
  name += final_path_.stem().string();
  name += ".tmp-";
  name += random_tag();
  name += final_path_.extension().string();
  temp_path_ = dir.empty() ? std::filesystem::path(name) : dir / name;
}

AtomicOutput::~AtomicOutput() {
  if (!committed_) {
    std::error_code ec;
    std::filesystem::remove(temp_path_, ec);
  }
}

void AtomicOutput::commit() {
  std::error_code ec;
  std::filesystem::rename(temp_path_, final_path_, ec);
  if (ec)
    throw std::runtime_error("cannot write " + final_path_.string() + ": " + ec.message());
  committed_ = true;
}

void write_file_atomically(const std::filesystem::path& path, std::string_view bytes) {
  AtomicOutput out(path);
  {
    std::ofstream f(out.temp_path(), std::ios::binary | std::ios::trunc);
    if (!f)
      throw std::runtime_error("cannot write " + path.string() +
                               ": the folder is missing or not writable");
    f.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    f.flush();
    if (!f) throw std::runtime_error("cannot write " + path.string() + ": write failed (disk full?)");
  }
  out.commit();
}

std::string read_file(const std::filesystem::path& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw std::runtime_error("cannot read " + path.string() + ": no such file or not readable");
  std::ostringstream ss;
  ss << f.rdbuf();
  if (f.bad()) throw std::runtime_error("cannot read " + path.string() + ": read error");
  return ss.str();
}

}  // namespace tactres
