#pragma once
// Outputs are written to a temporary sibling and renamed into place, so a
// failure never leaves a half-written file behind.

#include <filesystem>
#include <functional>
#include <memory>
#include <string_view>
#include <vector>

namespace tactres {

// A temporary path beside `final_path` that is renamed onto it by commit().
// If commit() is never called, the destructor removes the temporary file.
class AtomicOutput {
 public:
  explicit AtomicOutput(std::filesystem::path final_path);
  ~AtomicOutput();
  AtomicOutput(const AtomicOutput&) = delete;
  AtomicOutput& operator=(const AtomicOutput&) = delete;

  // Write here. It keeps the final extension so format-sniffing writers work.
  const std::filesystem::path& temp_path() const { return temp_path_; }
  const std::filesystem::path& final_path() const { return final_path_; }
  // Renames the temporary file onto the final path. Throws std::runtime_error
  // naming the path on failure.
  void commit();

 private:
  std::filesystem::path final_path_;
  std::filesystem::path temp_path_;
  bool committed_ = false;
};

// Several outputs written all-or-nothing (a capture's JSON, CSV and
// overlay; a target's six files): each is staged to its temporary sibling,
// and commit() renames them all into place. Should one stage or rename
// fail, nothing of the set is left: the staged files are removed, the ones
// already renamed too, and the earlier files they replaced are put back.
// Destroyed uncommitted, it leaves nothing.
class AtomicOutputSet {
 public:
  // Stages one output: `write` writes it to the temporary path it is given.
  // The output's folder is made when missing. Throws std::runtime_error
  // "cannot write <final path>: <why>" when `write` throws.
  void stage(const std::filesystem::path& final_path,
             const std::function<void(const std::filesystem::path& temp_path)>& write);
  // Stages `bytes` as the file `final_path`.
  void stage_bytes(const std::filesystem::path& final_path, std::string_view bytes);
  // Removes `path`, if it is a file, at commit: an earlier output that this
  // set does not replace and must not leave behind (an unusable capture's
  // old CSV and overlay beside its new JSON). Put back if the commit fails.
  void stage_removal(const std::filesystem::path& path);
  // Renames every staged output into place, over any earlier file of that
  // name, and removes the staged removals. Throws std::runtime_error naming the path on failure, having
  // removed the ones already renamed and put the earlier files back. A
  // second commit does nothing.
  void commit();
  // How many outputs were staged (and, after commit, written).
  size_t size() const { return outputs_.size(); }

 private:
  std::vector<std::unique_ptr<AtomicOutput>> outputs_;
  std::vector<std::filesystem::path> removals_;
  bool committed_ = false;
};

// One spelling of a path, whether or not the file exists: absolute, links
// resolved as far as the path exists, "." and ".." removed. Two paths to
// one file (relative and absolute, through a linked folder) get the same.
std::filesystem::path canonical_path(const std::filesystem::path& path);

// Refuses outputs that would destroy an input or each other: throws
// std::invalid_argument when one of `outputs` is the same file as one of
// `inputs` (by path, or by identity when both exist: a link) or as another
// output. Empty paths are skipped. Call it before anything is computed.
void refuse_colliding_outputs(const std::vector<std::filesystem::path>& outputs,
                              const std::vector<std::filesystem::path>& inputs);

// Writes `bytes` to `path` atomically. Throws std::runtime_error with the path.
void write_file_atomically(const std::filesystem::path& path, std::string_view bytes);

// Reads a whole file. Throws std::runtime_error with the path.
std::string read_file(const std::filesystem::path& path);

// The SHA-1 of a file's bytes, 40 lower-case hex digits (OpenImageIO's): what
// identifies a layout file whatever path it was given by. Throws as
// read_file does.
std::string file_sha1(const std::filesystem::path& path);

}  // namespace tactres
