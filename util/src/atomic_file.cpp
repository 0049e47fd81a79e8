#include "tactres/util/atomic_file.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <map>
#include <optional>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <system_error>

#include <OpenImageIO/hash.h>
#include <sys/stat.h>

namespace tactres {
namespace {

std::string random_tag() {
  static thread_local std::mt19937_64 rng{std::random_device{}()};
  static constexpr char kHex[] = "0123456789abcdef";
  std::string tag(8, '0');
  for (char& c : tag) c = kHex[rng() % 16];
  return tag;
}

// Writes `bytes` to `temp_path`, the temporary of `final_path` (named in
// the message).
void write_bytes(const std::filesystem::path& temp_path, const std::filesystem::path& final_path,
                 std::string_view bytes) {
  errno = 0;
  std::ofstream f(temp_path, std::ios::binary | std::ios::trunc);
  if (!f) {
    // The system's reason: a missing folder, no permission, or a name too
    // long for the file system.
    const std::string why = errno ? std::strerror(errno) : "the folder is missing or not writable";
    throw std::runtime_error("cannot write " + final_path.string() + ": " + why +
                             (errno == ENAMETOOLONG ? " (shorten the name)"
                              : errno == ENOENT     ? " (the folder is missing)"
                                                    : ""));
  }
  f.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  f.flush();
  if (!f) throw std::runtime_error("cannot write " + final_path.string() + ": write failed (disk full?)");
}

// ".name.<what>-XXXXXXXX.ext" beside `path`: hidden, unique, and with the
// real extension last (so that format-sniffing writers work). The stem is
// shortened, at a UTF-8 character's start, so that the name stays within
// kMaxNameBytes wherever the final name does (a 250-byte name had no
// temporary).
constexpr size_t kMaxNameBytes = 255;  // NAME_MAX of Linux's file systems
std::filesystem::path hidden_sibling(const std::filesystem::path& path, const char* what) {
  const std::string extension = path.extension().string();
  std::string stem = path.stem().string();
  const size_t fixed_bytes = 3 + std::strlen(what) + 8 + extension.size();  // ". . -" + tag
  size_t keep = std::min(stem.size(), kMaxNameBytes - std::min(kMaxNameBytes, fixed_bytes));
  while (keep > 0 && keep < stem.size() && (static_cast<unsigned char>(stem[keep]) & 0xC0) == 0x80) --keep;
  stem.resize(keep);
  std::string name = ".";  // appended piecewise: GCC 12 warns falsely on a chain of +
  name += stem;
  name += ".";
  name += what;
  name += "-";
  name += random_tag();
  name += extension;
  return path.has_parent_path() ? path.parent_path() / name : std::filesystem::path(name);
}

}  // namespace

AtomicOutput::AtomicOutput(std::filesystem::path final_path)
    : final_path_(std::move(final_path)), temp_path_(hidden_sibling(final_path_, "tmp")) {}

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
    throw std::runtime_error("cannot write " + final_path_.string() + ": " + ec.message() +
                             (ec == std::errc::filename_too_long ? " (shorten the name)" : ""));
  committed_ = true;
}

void write_file_atomically(const std::filesystem::path& path, std::string_view bytes) {
  AtomicOutput out(path);
  write_bytes(out.temp_path(), path, bytes);
  out.commit();
}

void AtomicOutputSet::stage(const std::filesystem::path& final_path,
                            const std::function<void(const std::filesystem::path&)>& write) {
  std::error_code ec;
  if (final_path.has_parent_path()) std::filesystem::create_directories(final_path.parent_path(), ec);
  outputs_.push_back(std::make_unique<AtomicOutput>(final_path));
  try {
    write(outputs_.back()->temp_path());
  } catch (const std::exception& e) {
    outputs_.pop_back();  // its half-written temporary goes with it, never to be committed
    const std::string why = e.what();
    // A message that names the output already (write_bytes) is not
    // prefixed twice.
    throw std::runtime_error(why.find(final_path.string()) != std::string::npos
                                 ? why
                                 : "cannot write " + final_path.string() + ": " + why);
  }
}

void AtomicOutputSet::stage_bytes(const std::filesystem::path& final_path, std::string_view bytes) {
  stage(final_path, [&](const std::filesystem::path& temp) { write_bytes(temp, final_path, bytes); });
}

void AtomicOutputSet::stage_removal(const std::filesystem::path& path) { removals_.push_back(path); }

void AtomicOutputSet::commit() {
  namespace fs = std::filesystem;
  if (committed_) return;
  // The files the outputs replace, and the ones to remove, are moved aside
  // first, and put back if any rename fails: a failed set leaves the
  // earlier results as they were.
  const size_t n = outputs_.size() + removals_.size();
  const auto path_of = [&](size_t k) -> const fs::path& {
    return k < outputs_.size() ? outputs_[k]->final_path() : removals_[k - outputs_.size()];
  };
  std::vector<fs::path> aside(n);
  size_t k = 0;
  try {
    for (; k < n; ++k) {
      const fs::path& final_path = path_of(k);
      std::error_code ec;
      if (fs::is_regular_file(final_path, ec)) {
        aside[k] = hidden_sibling(final_path, "old");
        fs::rename(final_path, aside[k], ec);
        if (ec) {
          aside[k].clear();
          throw std::runtime_error("cannot " + std::string(k < outputs_.size() ? "write " : "remove ") +
                                   final_path.string() + ": " + ec.message());
        }
      }
      if (k < outputs_.size()) outputs_[k]->commit();
    }
  } catch (...) {
    std::error_code ec;
    for (size_t j = 0; j < k && j < outputs_.size(); ++j) fs::remove(outputs_[j]->final_path(), ec);
    for (size_t j = 0; j <= k && j < n; ++j)
      if (!aside[j].empty()) fs::rename(aside[j], path_of(j), ec);
    throw;
  }
  std::error_code ec;
  for (const fs::path& a : aside)
    if (!a.empty()) fs::remove(a, ec);
  committed_ = true;
}

std::filesystem::path canonical_path(const std::filesystem::path& path) {
  // Absolute first: of a relative path none of whose parts exists,
  // weakly_canonical gives the path back as it was ("x.json" against
  // "./x.json").
  std::error_code ec;
  const std::filesystem::path absolute = std::filesystem::absolute(path, ec);
  const std::filesystem::path canonical = std::filesystem::weakly_canonical(ec ? path : absolute, ec);
  return (ec ? absolute : canonical).lexically_normal();
}

namespace {

// What identifies a file: its canonical path, and for one that exists its
// device and inode too (a hard or symbolic link to an input).
struct FileKeys {
  std::string path;
  std::optional<std::pair<dev_t, ino_t>> inode;
};

FileKeys keys_of(const std::filesystem::path& p) {
  FileKeys k{canonical_path(p).string(), std::nullopt};
  struct stat st {};
  if (::stat(p.c_str(), &st) == 0) k.inode = std::pair<dev_t, ino_t>(st.st_dev, st.st_ino);
  return k;
}

}  // namespace

void refuse_colliding_outputs(const std::vector<std::filesystem::path>& outputs,
                              const std::vector<std::filesystem::path>& inputs) {
  // Whose each key is: an input's, or an earlier output's.
  std::map<std::string, std::pair<bool, std::filesystem::path>> by_path;
  std::map<std::pair<dev_t, ino_t>, std::pair<bool, std::filesystem::path>> by_inode;
  for (const std::filesystem::path& in : inputs) {
    if (in.empty()) continue;
    const FileKeys k = keys_of(in);
    by_path.emplace(k.path, std::pair(true, in));
    if (k.inode) by_inode.emplace(*k.inode, std::pair(true, in));
  }
  for (const std::filesystem::path& out : outputs) {
    if (out.empty()) continue;
    const FileKeys k = keys_of(out);
    const std::pair<bool, std::filesystem::path>* owner = nullptr;
    if (const auto it = by_path.find(k.path); it != by_path.end()) owner = &it->second;
    if (const auto it = k.inode ? by_inode.find(*k.inode) : by_inode.end(); !owner && it != by_inode.end())
      owner = &it->second;
    if (owner && owner->first)
      throw std::invalid_argument("the output " + out.string() + " is also an input (" + owner->second.string() +
                                  "): writing it would destroy it; give the output another path");
    if (owner) throw std::invalid_argument("two outputs go to " + out.string() + ": give each its own file");
    by_path.emplace(k.path, std::pair(false, out));
    if (k.inode) by_inode.emplace(*k.inode, std::pair(false, out));
  }
}

std::string read_file(const std::filesystem::path& path) {
  // A folder opens as a stream that reads as empty: say what it is.
  if (std::error_code ec; std::filesystem::is_directory(path, ec))
    throw std::runtime_error("cannot read " + path.string() + ": it is a folder, not a file");
  std::ifstream f(path, std::ios::binary);
  if (!f) throw std::runtime_error("cannot read " + path.string() + ": no such file or not readable");
  std::ostringstream ss;
  ss << f.rdbuf();
  if (f.bad()) throw std::runtime_error("cannot read " + path.string() + ": read error");
  return ss.str();
}

std::string file_sha1(const std::filesystem::path& path) {
  const std::string bytes = read_file(path);
  std::string hex = OIIO::SHA1::digest(bytes.data(), bytes.size());
  std::transform(hex.begin(), hex.end(), hex.begin(), [](unsigned char c) { return std::tolower(c); });
  return hex;  // lower case, as sha1sum prints it
}

}  // namespace tactres
