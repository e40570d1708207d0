// Atomic creation of output files and folders.
//
// Every rrslam output is written under a temporary name beside its final name
// (`name.tmp`), flushed and fsynced, then renamed over the final name. A crash,
// an error or an exception therefore never leaves a half-written file under the
// final name, and an existing file is replaced only by a complete new one.
// Not thread-safe per object; distinct objects may be used from distinct threads.
#pragma once

#include <filesystem>
#include <string_view>

namespace rrslam {

// Reserves `final_path.tmp` for writing. The caller writes the temporary path by
// any means (ofstream, HDF5, EncodePng), then calls Commit(). If Commit() is
// never called, the destructor removes the temporary file or folder.
//
// Throws CantCreateError when the parent folder does not exist (or is a
// file) or is not writable, when the final path names an existing folder
// (for a file) or an existing file (for a folder), or when it names a
// device, FIFO or socket (`--out /dev/null`): such a path would be replaced
// by a regular file, so it is refused.
class AtomicOutput {
 public:
  enum class Kind { kFile, kDirectory };

  explicit AtomicOutput(std::filesystem::path final_path, Kind kind = Kind::kFile);
  ~AtomicOutput();
  AtomicOutput(const AtomicOutput&) = delete;
  AtomicOutput& operator=(const AtomicOutput&) = delete;

  const std::filesystem::path& temp_path() const { return temp_path_; }
  const std::filesystem::path& final_path() const { return final_path_; }

  // Fsyncs the temporary file (or every file of the temporary folder), renames
  // it to the final path and fsyncs the parent folder. An existing final folder
  // is replaced as a whole. Throws CantCreateError on failure; the final path
  // then keeps its previous content.
  void Commit();

 private:
  std::filesystem::path final_path_;
  std::filesystem::path temp_path_;
  Kind kind_;
  bool committed_ = false;
};

// Writes `content` to `path` atomically (see AtomicOutput).
void WriteFileAtomically(const std::filesystem::path& path, std::string_view content);

// Reads a whole file. Throws NoInputError when it cannot be opened.
std::string ReadFileToString(const std::filesystem::path& path);

}  // namespace rrslam
