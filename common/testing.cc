#include "common/testing.h"

#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <random>
#include <stdexcept>

#include "common/text.h"

namespace rrslam::testing {
namespace fs = std::filesystem;

TempDir::TempDir() {
  std::string pattern = (fs::temp_directory_path() / "rrslam_test_XXXXXX").string();
  if (::mkdtemp(pattern.data()) == nullptr) throw std::runtime_error("mkdtemp failed");
  path_ = pattern;
}

TempDir::~TempDir() {
  std::error_code ec;
  fs::remove_all(path_, ec);
}

std::optional<fs::path> SharedDataDir() {
  const char* env = std::getenv("RRSLAM_DATA_DIR");
  const fs::path dir = env != nullptr ? fs::path(env) : fs::path("../shared/data");
  std::error_code ec;
  if (fs::is_directory(dir / "settings", ec)) return dir;
  return std::nullopt;
}

bool ResetPeakResident() {
  std::ofstream clear("/proc/self/clear_refs");
  clear << "5";
  return static_cast<bool>(clear.flush()) && PeakResidentKb() >= 0;
}

long PeakResidentKb() {
  std::ifstream status("/proc/self/status");
  for (std::string line; std::getline(status, line);) {
    if (line.rfind("VmHWM:", 0) == 0) return std::stol(line.substr(6));
  }
  return -1;
}

fs::path BinDir() {
  const char* env = std::getenv("RRSLAM_BIN_DIR");
  return env != nullptr ? fs::path(env) : fs::path("build/bin");
}

fs::path FuzzSeedFolder(const TempDir& temp) {
  const char* dir = std::getenv("RRSLAM_WRITE_FUZZ_SEEDS");
  return dir != nullptr ? fs::path(dir) : temp.path();
}

fs::path SourceDir() {
  if (const char* env = std::getenv("RRSLAM_SOURCE_DIR")) return env;
  return fs::path(__FILE__).parent_path().parent_path();
}

std::string Quote(const fs::path& path) { return ShellQuote(path.string()); }

CommandResult RunCommand(const std::string& command_line) {
  CommandResult result;
  const std::string full = command_line + " 2>&1";
  FILE* pipe = ::popen(full.c_str(), "r");
  if (pipe == nullptr) return result;
  std::array<char, 4096> buffer;
  size_t n;
  while ((n = std::fread(buffer.data(), 1, buffer.size(), pipe)) > 0)
    result.output.append(buffer.data(), n);
  const int status = ::pclose(pipe);
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return result;
}

CommandResult RunTool(const std::string& stage, const std::string& args) {
  return RunCommand((BinDir() / ("rrslam-" + stage)).string() + " " + args);
}

void WriteTextFile(const fs::path& path, const std::string& content) {
  std::ofstream out(path, std::ios::binary);
  out << content;
}

std::vector<std::string> TemporaryLeftovers(const fs::path& dir) {
  std::vector<std::string> names;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(dir, ec)) {
    const std::string name = entry.path().filename().string();
    if (name.size() >= 4 && name.compare(name.size() - 4, 4, ".tmp") == 0) names.push_back(name);
  }
  std::sort(names.begin(), names.end());
  return names;
}

}  // namespace rrslam::testing
