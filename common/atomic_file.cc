#include "common/atomic_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <random>
#include <sstream>

#include "common/errors.h"

namespace rrslam {
namespace fs = std::filesystem;

namespace {

std::string ErrnoText() { return std::strerror(errno); }

void FsyncPath(const fs::path& path, bool directory) {
  const int fd = ::open(path.c_str(), directory ? (O_RDONLY | O_DIRECTORY) : O_RDONLY);
  if (fd < 0) throw CantCreateError(path.string() + ": cannot open for fsync: " + ErrnoText());
  const int rc = ::fsync(fd);
  ::close(fd);
  // Some file systems refuse fsync on folders (EINVAL); the data is still safe.
  if (rc != 0 && !(directory && errno == EINVAL)) {
    throw CantCreateError(path.string() + ": fsync failed: " + ErrnoText());
  }
}

void FsyncTree(const fs::path& dir) {
  for (const auto& entry : fs::recursive_directory_iterator(dir)) {
    FsyncPath(entry.path(), entry.is_directory());
  }
  FsyncPath(dir, true);
}

fs::path ParentOf(const fs::path& path) {
  const fs::path parent = path.parent_path();
  return parent.empty() ? fs::path(".") : parent;
}

std::atomic<atomic_output_testing::CommitHook> g_commit_hook{nullptr};
std::atomic<bool> g_force_rename_fallback{false};

void CommitStep(std::string_view step) {
  if (const auto hook = g_commit_hook.load()) hook(step);
}

// `<final>.<6 random characters><suffix>`, beside `final`.
fs::path UniqueSibling(const fs::path& final, std::string_view suffix) {
  static constexpr char kAlphabet[] = "abcdefghijklmnopqrstuvwxyz0123456789";
  thread_local std::mt19937_64 random(std::random_device{}() ^
                                      (static_cast<uint64_t>(::getpid()) << 32));
  std::string tag(6, 'x');
  for (char& c : tag) c = kAlphabet[random() % (sizeof(kAlphabet) - 1)];
  fs::path path = final;
  path += "." + tag;
  path += suffix;
  return path;
}

// Creates a new, empty temporary file or folder beside `final` under a name
// no other file has (O_EXCL / mkdir fail on an existing name: try another).
fs::path CreateUniqueTemporary(const fs::path& final, AtomicOutput::Kind kind) {
  for (int attempt = 0; attempt < 100; ++attempt) {
    const fs::path path = UniqueSibling(final, ".tmp");
    if (kind == AtomicOutput::Kind::kFile) {
      const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
      if (fd >= 0) {
        ::close(fd);
        return path;
      }
    } else if (::mkdir(path.c_str(), 0777) == 0) {
      return path;
    }
    if (errno != EEXIST) {
      throw CantCreateError(path.string() + ": cannot create: " + ErrnoText());
    }
  }
  throw CantCreateError(final.string() + ": no free temporary name beside it");
}

// Exchanges two existing paths atomically; false (errno set) when the file
// system or kernel cannot.
bool ExchangePaths(const fs::path& a, const fs::path& b) {
  if (g_force_rename_fallback.load()) {
    errno = EINVAL;
    return false;
  }
  return ::renameat2(AT_FDCWD, a.c_str(), AT_FDCWD, b.c_str(), RENAME_EXCHANGE) == 0;
}

}  // namespace

namespace atomic_output_testing {
void SetCommitHook(CommitHook hook) { g_commit_hook.store(hook); }
void SetForceRenameFallback(bool force) { g_force_rename_fallback.store(force); }
}  // namespace atomic_output_testing

AtomicOutput::AtomicOutput(fs::path final_path, Kind kind)
    : final_path_(std::move(final_path)), kind_(kind) {
  if (final_path_.empty()) throw CantCreateError("empty output path");
  if (!final_path_.has_filename()) final_path_ = final_path_.parent_path();
  const fs::path parent = ParentOf(final_path_);
  std::error_code ec;
  if (!fs::is_directory(parent, ec)) {
    throw CantCreateError(
        final_path_.string() + ": output folder " + parent.string() +
        (fs::exists(parent, ec) ? " is a file, not a folder" : " does not exist"));
  }
  if (::access(parent.c_str(), W_OK) != 0) {
    throw CantCreateError(final_path_.string() + ": output folder " + parent.string() +
                          " is not writable");
  }
  if (kind_ == Kind::kFile && fs::is_directory(final_path_, ec)) {
    throw CantCreateError(final_path_.string() + ": is a folder, expected a file path");
  }
  // A device, FIFO or socket (--out /dev/null) would be replaced by a
  // regular file by the final rename: refused.
  if (kind_ == Kind::kFile && fs::exists(final_path_, ec) &&
      !fs::is_regular_file(final_path_, ec) && !fs::is_directory(final_path_, ec)) {
    throw CantCreateError(final_path_.string() +
                          ": is not a regular file (a device, FIFO or socket); outputs are "
                          "written as regular files and replaced atomically");
  }
  if (kind_ == Kind::kDirectory && fs::exists(final_path_, ec) &&
      !fs::is_directory(final_path_, ec)) {
    throw CantCreateError(final_path_.string() + ": exists and is not a folder");
  }
  temp_path_ = CreateUniqueTemporary(final_path_, kind_);
}

AtomicOutput::~AtomicOutput() {
  if (!committed_) {
    std::error_code ec;
    fs::remove_all(temp_path_, ec);
  }
}

void AtomicOutput::Commit() {
  std::error_code ec;
  if (!fs::exists(temp_path_, ec)) {
    throw CantCreateError(final_path_.string() + ": nothing was written");
  }
  if (kind_ == Kind::kFile) {
    FsyncPath(temp_path_, false);
    if (::rename(temp_path_.c_str(), final_path_.c_str()) != 0) {
      throw CantCreateError(final_path_.string() + ": cannot rename from " + temp_path_.string() +
                            ": " + ErrnoText());
    }
  } else {
    FsyncTree(temp_path_);
    if (!fs::exists(final_path_, ec)) {
      if (::rename(temp_path_.c_str(), final_path_.c_str()) != 0) {
        throw CantCreateError(final_path_.string() + ": cannot rename from " + temp_path_.string() +
                              ": " + ErrnoText());
      }
    } else if (ExchangePaths(temp_path_, final_path_)) {
      // The final name now holds the new folder; the old one is under the
      // temporary name, which this object owns.
      committed_ = true;
      CommitStep("exchanged");
      fs::remove_all(temp_path_, ec);
    } else if (errno == EINVAL || errno == ENOSYS || errno == ENOTSUP) {
      // rename(2) cannot replace a non-empty folder: move the old one aside.
      const fs::path old_path = UniqueSibling(final_path_, ".old.tmp");
      if (::rename(final_path_.c_str(), old_path.c_str()) != 0) {
        throw CantCreateError(final_path_.string() +
                              ": cannot move the old folder aside: " + ErrnoText());
      }
      CommitStep("moved-aside");
      if (::rename(temp_path_.c_str(), final_path_.c_str()) != 0) {
        const std::string why = ErrnoText();
        ::rename(old_path.c_str(), final_path_.c_str());
        throw CantCreateError(final_path_.string() + ": cannot rename from " + temp_path_.string() +
                              ": " + why);
      }
      fs::remove_all(old_path, ec);
    } else {
      throw CantCreateError(final_path_.string() + ": cannot exchange with " + temp_path_.string() +
                            ": " + ErrnoText());
    }
  }
  FsyncPath(ParentOf(final_path_), true);
  committed_ = true;
}

void WriteFileAtomically(const fs::path& path, std::string_view content) {
  AtomicOutput out(path);
  {
    std::ofstream stream(out.temp_path(), std::ios::binary | std::ios::trunc);
    if (!stream) throw CantCreateError(out.temp_path().string() + ": cannot open for writing");
    stream.write(content.data(), static_cast<std::streamsize>(content.size()));
    stream.flush();
    if (!stream) throw CantCreateError(out.temp_path().string() + ": write failed");
  }
  out.Commit();
}

std::string ReadFileToString(const fs::path& path) {
  std::error_code ec;
  if (fs::is_directory(path, ec))
    throw NoInputError(path.string() + ": is a folder, expected a file");
  std::ifstream stream(path, std::ios::binary);
  if (!stream) throw NoInputError(path.string() + ": cannot open: " + ErrnoText());
  std::ostringstream buffer;
  buffer << stream.rdbuf();
  return buffer.str();
}

}  // namespace rrslam
