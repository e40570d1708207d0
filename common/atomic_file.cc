#include "common/atomic_file.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
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

}  // namespace

AtomicOutput::AtomicOutput(fs::path final_path, Kind kind)
    : final_path_(std::move(final_path)), kind_(kind) {
  if (final_path_.empty()) throw CantCreateError("empty output path");
  if (!final_path_.has_filename()) final_path_ = final_path_.parent_path();
  temp_path_ = final_path_;
  temp_path_ += ".tmp";
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
  fs::remove_all(temp_path_, ec);  // A stale temporary from a crashed run.
  if (kind_ == Kind::kDirectory) {
    if (!fs::create_directory(temp_path_, ec)) {
      throw CantCreateError(temp_path_.string() + ": cannot create folder: " + ec.message());
    }
  }
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
    // rename(2) cannot replace a non-empty folder: move the old one aside first.
    fs::path old_path = final_path_;
    old_path += ".old.tmp";
    const bool had_old = fs::exists(final_path_, ec);
    if (had_old) {
      fs::remove_all(old_path, ec);
      if (::rename(final_path_.c_str(), old_path.c_str()) != 0) {
        throw CantCreateError(final_path_.string() +
                              ": cannot move the old folder aside: " + ErrnoText());
      }
    }
    if (::rename(temp_path_.c_str(), final_path_.c_str()) != 0) {
      const std::string why = ErrnoText();
      if (had_old) ::rename(old_path.c_str(), final_path_.c_str());
      throw CantCreateError(final_path_.string() + ": cannot rename from " + temp_path_.string() +
                            ": " + why);
    }
    if (had_old) fs::remove_all(old_path, ec);
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
