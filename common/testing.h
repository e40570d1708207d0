// Helpers shared by rrslam's tests (linked into every test binary).
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace rrslam::testing {

// A fresh temporary folder, removed with its content on destruction.
class TempDir {
 public:
  TempDir();
  ~TempDir();
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::filesystem::path& path() const { return path_; }
  std::filesystem::path operator/(const std::string& name) const { return path_ / name; }

 private:
  std::filesystem::path path_;
};

// The shared data root (RRSLAM_DATA_DIR), or nullopt when it is absent; tests
// that need it call GTEST_SKIP() with a message in that case.
std::optional<std::filesystem::path> SharedDataDir();

// Folder of the rrslam-* executables (RRSLAM_BIN_DIR).
std::filesystem::path BinDir();

// The bytes of `text` (which must outlive the span).
inline std::span<const uint8_t> Bytes(std::string_view text) {
  return {reinterpret_cast<const uint8_t*>(text.data()), text.size()};
}

// Where a fuzz seed test writes its corpora: the folder
// RRSLAM_WRITE_FUZZ_SEEDS names (`make fuzz-seeds` sets it to the committed
// seeds' folder), else `temp`.
std::filesystem::path FuzzSeedFolder(const TempDir& temp);

// Root of the source tree (RRSLAM_SOURCE_DIR, else the tree this file was
// compiled from): for tests that run its Makefile or scripts.
std::filesystem::path SourceDir();

// Peak resident memory of this process, kB (VmHWM of /proc/self/status; -1
// when unknown), for tests that a refused input is refused before it is read
// or allocated: ResetPeakResident() first sets the peak to the current
// resident size, and returns false where the kernel does not allow it (the
// test then skips).
bool ResetPeakResident();
long PeakResidentKb();

// `path` single-quoted for a shell command line (ShellQuote).
std::string Quote(const std::filesystem::path& path);

struct CommandResult {
  int exit_code = -1;
  std::string output;  // stdout and stderr together.
};

// Runs a shell command line and returns its exit code and output.
CommandResult RunCommand(const std::string& command_line);

// Runs `rrslam-<stage> <args>` from BinDir().
CommandResult RunTool(const std::string& stage, const std::string& args);

// Writes a text file (not atomically; test fixtures only).
void WriteTextFile(const std::filesystem::path& path, const std::string& content);

// Names of the temporaries AtomicOutput leaves in `dir` (entries whose name
// ends in ".tmp", see common/atomic_file.h), sorted; empty when none (or
// when `dir` does not exist). A finished or failed write must leave none.
std::vector<std::string> TemporaryLeftovers(const std::filesystem::path& dir);
// what() of the exception of type E that `fn` throws, or "no error" (other
// exceptions pass through): for tests of one-line error messages.
template <typename E, typename Fn>
std::string ErrorMessage(Fn&& fn) {
  try {
    fn();
  } catch (const E& e) {
    return e.what();
  }
  return "no error";
}

inline std::vector<std::string> TemporaryLeftovers(const TempDir& dir) {
  return TemporaryLeftovers(dir.path());
}

}  // namespace rrslam::testing

// Skips the current test when the shared data is absent; defines `data_dir`.
#define RRSLAM_REQUIRE_SHARED_DATA(data_dir)                                          \
  const auto data_dir##_opt = ::rrslam::testing::SharedDataDir();                     \
  if (!data_dir##_opt) GTEST_SKIP() << "shared data not found (set RRSLAM_DATA_DIR)"; \
  const std::filesystem::path data_dir = *data_dir##_opt
