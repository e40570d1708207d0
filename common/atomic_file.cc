#include "common/atomic_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>
#include <regex>
#include <sstream>

#include "common/errors.h"
#include "common/path_check.h"
#include "common/temporaries.h"

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

// `<final>.<6 random characters><suffix>`, beside `final`. A final name
// too long for that within the file system's 255-byte limit on a name is cut
// short in the temporary name (a legal 250-byte output name must not fail).
fs::path UniqueSibling(const fs::path& final, std::string_view suffix) {
  static constexpr char kAlphabet[] = "abcdefghijklmnopqrstuvwxyz0123456789";
  static constexpr size_t kMaxName = 255;  // NAME_MAX of ext4, xfs, btrfs, tmpfs.
  thread_local std::mt19937_64 random(std::random_device{}() ^
                                      (static_cast<uint64_t>(::getpid()) << 32));
  std::string tag(6, 'x');
  for (char& c : tag) c = kAlphabet[random() % (sizeof(kAlphabet) - 1)];
  std::string name = final.filename().string();
  const size_t room = kMaxName - 1 - tag.size() - suffix.size();
  if (name.size() > room) name.resize(room);
  return final.parent_path() / (name + "." + tag + std::string(suffix));
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

bool IsRegularFile(const fs::path& path) {
  std::error_code ec;
  return fs::symlink_status(path, ec).type() == fs::file_type::regular;
}

bool IsFolder(const fs::path& path) {
  std::error_code ec;
  return fs::symlink_status(path, ec).type() == fs::file_type::directory;
}

// Entry names of `dir`, sorted (so the first foreign one is the same every run).
std::vector<std::string> SortedNames(const fs::path& dir, const fs::path& shown) {
  std::vector<std::string> names;
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    names.push_back(it->path().filename().string());
  }
  if (ec) throw CantCreateError(shown.string() + ": cannot list the folder: " + ec.message());
  std::sort(names.begin(), names.end());
  return names;
}

// At most `limit` bytes of a small file ("" when it cannot be read).
std::string ReadHead(const fs::path& path, size_t limit) {
  std::ifstream stream(path, std::ios::binary);
  std::string text(limit, '\0');
  stream.read(text.data(), static_cast<std::streamsize>(limit));
  text.resize(static_cast<size_t>(std::max<std::streamsize>(stream.gcount(), 0)));
  return text;
}

// The tool named by a marker file: its first line, without trailing blanks.
std::string MarkerTool(const fs::path& path) {
  if (!IsRegularFile(path)) return "";
  std::string text = ReadHead(path, 256);
  text = text.substr(0, text.find('\n'));
  while (!text.empty() && std::isspace(static_cast<unsigned char>(text.back()))) text.pop_back();
  return text;
}

// The "producer" of a JSON record ("" when it has none or is not JSON). Run
// reports are kilobytes; a record over 64 MiB is not one.
std::string RecordProducer(const fs::path& path) {
  std::error_code ec;
  const uintmax_t size = fs::file_size(path, ec);
  if (ec || size > (uintmax_t{64} << 20)) return "";
  const nlohmann::json record =
      nlohmann::json::parse(ReadHead(path, static_cast<size_t>(size)), nullptr, false);
  if (!record.is_object()) return "";
  const auto producer = record.find("producer");
  return producer != record.end() && producer->is_string() ? producer->get<std::string>() : "";
}

// The first entry of the existing folder `dir` that `owner` did not write,
// as the error names it ("notes.txt", "rgb/x.png", ".rrslam-output of
// rrslam-synth"); "" when the folder is the owner's (see OutputFolderOwner).
// `shown` is the folder's name in messages.
std::string ForeignEntry(const fs::path& dir, const fs::path& shown,
                         const OutputFolderOwner& owner) {
  const std::vector<std::string> names = SortedNames(dir, shown);
  const auto owned_file = [&](const std::string& name) {
    return std::find(owner.files.begin(), owner.files.end(), name) != owner.files.end();
  };
  bool marked = false;
  for (const std::string& name : names) {
    const fs::path path = dir / name;
    if (name == kOutputFolderMarker) {
      const std::string tool = MarkerTool(path);
      if (!owner.tool.empty() && tool == owner.tool) {
        marked = true;
        continue;
      }
      return tool.empty() ? name : name + " of " + tool;
    }
    if (owned_file(name)) {
      if (IsRegularFile(path)) continue;
      return name;
    }
    const auto folder = std::find_if(owner.folders.begin(), owner.folders.end(),
                                     [&](const auto& f) { return f.name == name; });
    if (folder == owner.folders.end() || !IsFolder(path)) return name;
    const std::regex pattern(folder->file_pattern);
    for (const std::string& inner : SortedNames(path, shown / name)) {
      if (!IsRegularFile(path / inner) || !std::regex_match(inner, pattern)) {
        return name + "/" + inner;
      }
    }
  }
  // A folder without the marker: an older version's output only with its record.
  if (names.empty() || marked || owner.record.empty()) return "";
  if (std::find(names.begin(), names.end(), owner.record) == names.end()) {
    return names.front() + ", without " + owner.record + " of " + owner.tool;
  }
  const std::string producer = RecordProducer(dir / owner.record);
  if (producer.rfind(owner.tool + " ", 0) == 0 || producer == owner.tool) return "";
  return owner.record + " of " + (producer.empty() ? "another tool" : producer);
}

// Whether `dir` is the current working folder or one of its ancestors.
bool HoldsWorkingFolder(const fs::path& dir) {
  std::error_code ec;
  const fs::path real = fs::canonical(dir, ec);
  if (ec) return false;
  const fs::path cwd = fs::current_path(ec);
  if (ec) return false;
  return std::mismatch(real.begin(), real.end(), cwd.begin(), cwd.end()).first == real.end();
}

// Throws CantCreateError unless the existing folder `final` may be replaced
// by an output of `owner` (see AtomicOutput's constructor). No-op when
// nothing is at `final`.
void CheckFolderMayBeReplaced(const fs::path& final, const OutputFolderOwner& owner) {
  std::error_code ec;
  const fs::file_status status = fs::symlink_status(final, ec);
  if (ec || status.type() == fs::file_type::not_found) return;
  if (status.type() == fs::file_type::symlink) {
    throw CantCreateError(final.string() +
                          ": is a symbolic link; give a folder path (the output folder would "
                          "replace the link)");
  }
  if (status.type() != fs::file_type::directory) {
    throw CantCreateError(final.string() + ": exists and is not a folder");
  }
  if (HoldsWorkingFolder(final)) {
    throw CantCreateError(final.string() +
                          ": is the current folder or holds it; give another folder (the output "
                          "folder is replaced by a new one)");
  }
  const std::string foreign = ForeignEntry(final, final, owner);
  if (foreign.empty()) return;
  if (owner.tool.empty()) {
    throw CantCreateError(final.string() + ": is not empty (" + foreign +
                          "); give an empty or new folder");
  }
  throw CantCreateError(final.string() + ": holds files " + owner.tool + " did not write (" +
                        foreign + "); give an empty or new folder, or one an earlier " +
                        owner.tool + " run wrote");
}

// Removes `old`, the folder an output replaced, now under a temporary name;
// keeps it there if an entry not the owner's got in after the last check.
void RemoveReplacedFolder(const fs::path& old, const fs::path& final,
                          const OutputFolderOwner& owner) {
  std::string foreign;
  try {
    foreign = ForeignEntry(old, final, owner);
  } catch (const CantCreateError& e) {
    foreign = e.what();
  }
  std::error_code ec;
  if (foreign.empty()) {
    fs::remove_all(old, ec);
  } else {
    // Written plainly: this file is also built without spdlog (the fuzzers).
    std::fprintf(stderr, "warning: %s: the folder it replaced got %s meanwhile; kept as %s\n",
                 final.c_str(), foreign.c_str(), old.c_str());
  }
}

}  // namespace

namespace atomic_output_testing {
void SetCommitHook(CommitHook hook) { g_commit_hook.store(hook); }
void SetForceRenameFallback(bool force) { g_force_rename_fallback.store(force); }
}  // namespace atomic_output_testing

AtomicOutput::AtomicOutput(fs::path final_path, Kind kind, OutputFolderOwner owner)
    : final_path_(std::move(final_path)), kind_(kind), owner_(std::move(owner)) {
  if (final_path_.empty()) throw CantCreateError("empty output path");
  if (!final_path_.has_filename()) final_path_ = final_path_.parent_path();
  // "x/." and "x/.." name a folder by a name the temporary could not sit
  // beside (it would land inside x).
  if (kind_ == Kind::kDirectory &&
      (final_path_.filename() == "." || final_path_.filename() == "..")) {
    std::error_code ec;
    const fs::path resolved = fs::weakly_canonical(final_path_, ec);
    if (!ec) final_path_ = resolved;
  }
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
  if (kind_ == Kind::kDirectory) CheckFolderMayBeReplaced(final_path_, owner_);
  {
    const auto lock = LockTemporaries();
    temp_path_ = CreateUniqueTemporary(final_path_, kind_);
    RegisterTemporary(temp_path_);
  }
  if (kind_ == Kind::kDirectory && !owner_.tool.empty()) {
    const fs::path marker = temp_path_ / kOutputFolderMarker;
    std::ofstream stream(marker, std::ios::binary);
    stream << owner_.tool << "\n";
    stream.flush();
    if (!stream) {
      const auto lock = LockTemporaries();
      fs::remove_all(temp_path_, ec);  // No destructor runs for a throwing constructor.
      ForgetTemporary(temp_path_);
      throw CantCreateError(marker.string() + ": cannot write");
    }
  }
}

AtomicOutput::~AtomicOutput() {
  const auto lock = LockTemporaries();
  if (!committed_) {
    std::error_code ec;
    fs::remove_all(temp_path_, ec);
  }
  // Committed, the temporary name is gone or holds a replaced folder kept
  // on purpose (see Commit): not to be removed on an interruption either.
  ForgetTemporary(temp_path_);
}

void AtomicOutput::Commit() {
  std::error_code ec;
  if (!fs::exists(temp_path_, ec)) {
    throw CantCreateError(final_path_.string() + ": nothing was written");
  }
  // From the first rename on, an interruption waits for the commit to end.
  std::unique_lock<std::recursive_mutex> lock;
  if (kind_ == Kind::kFile) {
    FsyncPath(temp_path_, false);
    lock = LockTemporaries();
    if (::rename(temp_path_.c_str(), final_path_.c_str()) != 0) {
      throw CantCreateError(final_path_.string() + ": cannot rename from " + temp_path_.string() +
                            ": " + ErrnoText());
    }
  } else {
    FsyncTree(temp_path_);
    const bool replacing = fs::symlink_status(final_path_, ec).type() != fs::file_type::not_found;
    // The folder may have changed since the constructor's check.
    if (replacing) CheckFolderMayBeReplaced(final_path_, owner_);
    lock = LockTemporaries();
    if (!replacing) {
      if (::rename(temp_path_.c_str(), final_path_.c_str()) != 0) {
        throw CantCreateError(final_path_.string() + ": cannot rename from " + temp_path_.string() +
                              ": " + ErrnoText());
      }
    } else if (ExchangePaths(temp_path_, final_path_)) {
      // The final name now holds the new folder; the old one is under the
      // temporary name, which this object owns.
      committed_ = true;
      CommitStep("exchanged");
      RemoveReplacedFolder(temp_path_, final_path_, owner_);
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
      RemoveReplacedFolder(old_path, final_path_, owner_);
    } else {
      throw CantCreateError(final_path_.string() + ": cannot exchange with " + temp_path_.string() +
                            ": " + ErrnoText());
    }
  }
  committed_ = true;
  ForgetTemporary(temp_path_);
  lock.unlock();
  FsyncPath(ParentOf(final_path_), true);
}

void CommitContent(AtomicOutput* out, std::string_view content) {
  {
    std::ofstream stream(out->temp_path(), std::ios::binary | std::ios::trunc);
    if (!stream) throw CantCreateError(out->temp_path().string() + ": cannot open for writing");
    stream.write(content.data(), static_cast<std::streamsize>(content.size()));
    stream.flush();
    if (!stream) throw CantCreateError(out->temp_path().string() + ": write failed");
  }
  out->Commit();
}

void WriteFileAtomically(const fs::path& path, std::string_view content) {
  AtomicOutput out(path);
  CommitContent(&out, content);
}

std::string ReadFileToString(const fs::path& path) {
  // A pipe is read (`--gt <(zcat gt.txt.gz)`); a device never ends
  // (/dev/zero) or is not data: refused, as a folder is.
  const std::string why = WhyNotAFile(path);
  if (!why.empty() && why != kPathIsAFifo && why != kPathDoesNotExist) {
    throw NoInputError(path.string() + ": " + why + ", expected a file");
  }
  std::ifstream stream(path, std::ios::binary);
  if (!stream) throw NoInputError(path.string() + ": cannot open: " + ErrnoText());
  std::ostringstream buffer;
  buffer << stream.rdbuf();
  return buffer.str();
}

}  // namespace rrslam
