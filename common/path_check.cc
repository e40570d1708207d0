#include "common/path_check.h"

#include <sys/stat.h>

#include <cerrno>
#include <cstring>

#include "common/errors.h"

namespace rrslam {
namespace {

// "" for the wanted type; else what the path is or why it cannot be looked at.
std::string Describe(const std::filesystem::path& path, bool want_folder) {
  struct stat info = {};
  if (::stat(path.c_str(), &info) != 0) {
    const int error = errno;
    if (error == ENOENT) {
      struct stat link = {};
      return ::lstat(path.c_str(), &link) == 0 ? "is a broken symbolic link" : kPathDoesNotExist;
    }
    if (error == ENAMETOOLONG) return "has a name longer than the system allows";
    return std::string("cannot be reached: ") + std::strerror(error);
  }
  const mode_t type = info.st_mode & S_IFMT;
  if (type == (want_folder ? S_IFDIR : S_IFREG)) return "";
  switch (type) {
    case S_IFREG:
      return "is a regular file";
    case S_IFDIR:
      return "is a folder";
    case S_IFIFO:
      return kPathIsAFifo;
    case S_IFCHR:
      return "is a character device";
    case S_IFBLK:
      return "is a block device";
    case S_IFSOCK:
      return "is a socket";
    default:
      return "is not a regular file or folder";
  }
}

void Require(const std::filesystem::path& path, const std::string& what, bool folder) {
  const std::string why = Describe(path, folder);
  if (why.empty()) return;
  if (why == kPathDoesNotExist) throw NoInputError(path.string() + ": no such " + what);
  throw NoInputError(path.string() + ": " + why + ", not a " + what);
}

}  // namespace

std::string WhyNotAFile(const std::filesystem::path& path) { return Describe(path, false); }

std::string WhyNotAFolder(const std::filesystem::path& path) { return Describe(path, true); }

void RequireFile(const std::filesystem::path& path, const std::string& what) {
  Require(path, what, false);
}

void RequireFolder(const std::filesystem::path& path, const std::string& what) {
  Require(path, what, true);
}

}  // namespace rrslam
