// Atomic creation of output files and folders.
//
// Every rrslam output is written under a temporary name beside its final name,
// flushed and fsynced, then renamed over the final name. A crash, an error or
// an exception therefore never leaves a half-written file under the final
// name, and an existing file is replaced only by a complete new one.
//
// Temporary names are unique: `<name>.<6 random characters>.tmp`, created
// with O_EXCL (a file) or mkdir (a folder), so they never collide with a
// user's file or with another run writing the same output; only the
// temporary the object itself created is ever removed. A process killed
// (SIGKILL) while writing leaves its `<name>.XXXXXX.tmp` behind, never a
// damaged final name; such leftovers may be deleted by hand.
//
// An existing output folder is replaced in one step with
// renameat2(RENAME_EXCHANGE) (Linux >= 3.15 on ext4, xfs, btrfs, tmpfs and
// most local file systems): the final name always holds a complete folder,
// the old or the new one; the old folder, now under the temporary name, is
// then removed. Where the file system refuses the exchange (EINVAL, ENOSYS,
// e.g. some network file systems), the fallback takes two renames (old folder
// aside to `<name>.XXXXXX.old.tmp`, new folder in); a kill between those two
// leaves no folder under the final name, but the old one intact under the
// `.old.tmp` name.
//
// Not thread-safe per object; distinct objects may be used from distinct threads.
#pragma once

#include <filesystem>
#include <string_view>

namespace rrslam {

// Reserves a unique temporary path beside `final_path` (created empty: a file
// for Kind::kFile, a folder for Kind::kDirectory). The caller writes the
// temporary path by any means (ofstream, HDF5, OpenImageIO; the name ends in
// ".tmp", so writers that choose a format by extension must be told it), then
// calls Commit(). If Commit() is never called, the destructor removes the
// temporary file or folder.
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
  // is replaced as a whole (exchanged, see above). Throws CantCreateError on
  // failure; the final path then keeps its previous content.
  void Commit();

 private:
  std::filesystem::path final_path_;
  std::filesystem::path temp_path_;
  Kind kind_;
  bool committed_ = false;
};

// Fault injection for tests of Commit() on folders. The hook, when set, is
// called at each step: "exchanged" (RENAME_EXCHANGE done, old folder not yet
// removed) and, in the fallback, "moved-aside" (old folder renamed aside, new
// one not yet in place). A test's hook may kill the process there.
// `force_rename_fallback` makes Commit() use the two-rename fallback.
namespace atomic_output_testing {
using CommitHook = void (*)(std::string_view step);
void SetCommitHook(CommitHook hook);
void SetForceRenameFallback(bool force);
}  // namespace atomic_output_testing

// Writes `content` to `path` atomically (see AtomicOutput).
void WriteFileAtomically(const std::filesystem::path& path, std::string_view content);

// Reads a whole file. Throws NoInputError when it cannot be opened.
std::string ReadFileToString(const std::filesystem::path& path);

}  // namespace rrslam
