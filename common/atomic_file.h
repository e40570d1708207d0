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
// temporary the object itself created is ever removed. A final name too
// long for the suffix within 255 bytes is cut short in the temporary's name.
// Every live temporary is registered (common/temporaries.h): interrupted by
// SIGINT, SIGTERM or SIGHUP, a tool removes them before it dies. A process
// killed by SIGKILL while writing leaves its `<name>.XXXXXX.tmp` behind,
// never a damaged final name; such leftovers may be deleted by hand.
//
// An existing output folder is replaced only when it is empty or holds
// nothing but an earlier output of the same tool (OutputFolderOwner below):
// a tool never deletes what it did not write (issue 36: `--out .` or
// `--out ~/runs` must not take the user's notes and sub-folders with it).
// Every new output folder carries a marker file, `.rrslam-output`, naming the
// tool. The rule is checked when the AtomicOutput is made (so a run fails
// before its work) and again in Commit() just before the replacement.
//
// Such a folder is replaced in one step with
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
#include <string>
#include <string_view>
#include <vector>

namespace rrslam {

// Name of the marker file in every output folder of an owned AtomicOutput
// (Kind::kDirectory): a regular file whose text is the tool's name and a
// newline ("rrslam-track\n").
inline constexpr std::string_view kOutputFolderMarker = ".rrslam-output";

// The tool that writes an output folder and the names it writes there: what
// may be replaced. An existing folder at the final path is the tool's own, and
// may be replaced, when it is empty, or when every entry in it is one of:
//   - the marker naming `tool` (a marker naming another tool is foreign);
//   - a regular file named in `files`;
//   - a folder named in `folders` holding only regular files whose names
//     match its `file_pattern`;
// and, in a folder without the marker (written by a version before it), the
// file `record` is among them and is JSON whose "producer" names the tool
// ("rrslam-track 0.3"): CameraTrajectory.txt and KeyFrameTrajectory.txt
// alone are what ORB-SLAM2 writes, not an rrslam-track output.
// Symbolic links are never the tool's (they are not followed). Anything else,
// e.g. the user's notes.txt, makes the folder foreign: it is not replaced.
struct OutputFolderOwner {
  // The tool, as named in the marker and in its record's "producer":
  // "rrslam-track". Empty: no marker is written and only an empty folder is
  // replaced.
  std::string tool;
  // Regular files the tool writes at the top of its folder ("run.json").
  std::vector<std::string> files;
  // Sub-folders the tool writes, each of regular files only.
  struct Folder {
    std::string name;          // "rgb"
    std::string file_pattern;  // ECMAScript regex for a whole file name: R"(\d+\.\d{6}\.png)"
  };
  std::vector<Folder> folders;
  // One of `files`, a JSON record with "producer"; empty: a folder without the
  // marker is the tool's by its names alone.
  std::string record;
};

// Reserves a unique temporary path beside `final_path` (created empty: a file
// for Kind::kFile, a folder for Kind::kDirectory). The caller writes the
// temporary path by any means (ofstream, HDF5, OpenImageIO; the name ends in
// ".tmp", so writers that choose a format by extension must be told it), then
// calls Commit(). If Commit() is never called, the destructor removes the
// temporary file or folder.
//
// For Kind::kDirectory, `owner` says which existing folder may be replaced
// (see OutputFolderOwner); with a tool named, the marker is written into the
// temporary folder at once, so the committed folder always carries it. A
// final path "x/." or "x/.." is resolved to the folder it names.
//
// Throws CantCreateError when the parent folder does not exist (or is a
// file) or is not writable, when the final path names an existing folder
// (for a file) or an existing file (for a folder), or when it names a
// device, FIFO or socket (`--out /dev/null`): such a path would be replaced
// by a regular file, so it is refused. For a folder also when the final path
// is a symbolic link, is the current working folder or holds it (replacing it
// would leave the process and the user's shell in a deleted folder), or is an
// existing folder that is not the owner's; the message is one line naming the
// folder and the first foreign entry (by name; "rgb/x.png" inside a
// sub-folder):
//   runs: holds files rrslam-track did not write (notes.txt); give an empty
//   or new folder, or one an earlier rrslam-track run wrote
// Nothing is then created or changed.
class AtomicOutput {
 public:
  enum class Kind { kFile, kDirectory };

  explicit AtomicOutput(std::filesystem::path final_path, Kind kind = Kind::kFile,
                        OutputFolderOwner owner = {});
  ~AtomicOutput();
  AtomicOutput(const AtomicOutput&) = delete;
  AtomicOutput& operator=(const AtomicOutput&) = delete;

  const std::filesystem::path& temp_path() const { return temp_path_; }
  const std::filesystem::path& final_path() const { return final_path_; }

  // Fsyncs the temporary file (or every file of the temporary folder), renames
  // it to the final path and fsyncs the parent folder. An existing final folder
  // is checked again (it may have changed since the constructor) and, if still
  // the owner's, replaced as a whole (exchanged, see above); if not, Commit()
  // throws the constructor's CantCreateError and leaves it as it is. Should a
  // foreign entry appear in the moment between that check and the exchange,
  // the old folder is kept under its `.tmp` name (a warning names it), not
  // removed. Throws CantCreateError on failure; the final path then keeps its
  // previous content.
  void Commit();

 private:
  std::filesystem::path final_path_;
  std::filesystem::path temp_path_;
  Kind kind_;
  OutputFolderOwner owner_;
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

// Writes `content` into a file output's temporary file and commits it: for a
// tool that reserves its outputs before the work (their folders checked
// early) and fills them at the end.
void CommitContent(AtomicOutput* out, std::string_view content);

// Reads a whole file, or a pipe to its end. Throws NoInputError when it
// cannot be opened or is a folder or device ("/dev/zero: is a character
// device, expected a file").
std::string ReadFileToString(const std::filesystem::path& path);

}  // namespace rrslam
