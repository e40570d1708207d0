// What is at a path, in words for one-line error messages.
//
// `--settings /dev/zero` is not "no such settings file", a FIFO listed as an
// image is not "listed image does not exist", and a path longer than the
// system allows is not "no such sequence folder" (issue 36): an input that
// is not what it should be is named for what it is.
#pragma once

#include <filesystem>
#include <string>

namespace rrslam {

// Two of the reasons below, for callers that treat them apart.
inline constexpr char kPathDoesNotExist[] = "does not exist";
inline constexpr char kPathIsAFifo[] = "is a FIFO";

// Why `path` (symbolic links followed) is not a regular file, or "" when it
// is one: "does not exist", "is a broken symbolic link", "is a folder",
// "is a FIFO", "is a character device", "is a block device", "is a socket",
// "has a name longer than the system allows", or "cannot be reached:
// <strerror>" (a folder on its way is not readable or is a file).
std::string WhyNotAFile(const std::filesystem::path& path);

// The same for a folder: "" when `path` is one, else "is a regular file" or
// one of WhyNotAFile's reasons.
std::string WhyNotAFolder(const std::filesystem::path& path);

// Throw NoInputError unless `path` is a regular file (a folder): missing,
// "<path>: no such <what>"; else "<path>: <reason>, not a <what>"
// ("/dev/zero: is a character device, not a settings file").
void RequireFile(const std::filesystem::path& path, const std::string& what);
void RequireFolder(const std::filesystem::path& path, const std::string& what);

}  // namespace rrslam
