#pragma once
// Outputs are written to a temporary sibling and renamed into place, so a
// failure never leaves a half-written file behind.

#include <filesystem>
#include <string_view>

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

// Writes `bytes` to `path` atomically. Throws std::runtime_error with the path.
void write_file_atomically(const std::filesystem::path& path, std::string_view bytes);

// Reads a whole file. Throws std::runtime_error with the path.
std::string read_file(const std::filesystem::path& path);

}  // namespace tactres
