#include "common/output_path.h"

#include <sys/stat.h>

namespace rrslam {
namespace {

namespace fs = std::filesystem;

fs::path Canonical(const fs::path& path) {
  std::error_code ec;
  fs::path absolute = fs::absolute(path, ec);
  if (ec) absolute = path;
  fs::path canonical = fs::weakly_canonical(absolute, ec);
  if (ec) canonical = absolute.lexically_normal();
  // "dir/" and "dir" are the same folder.
  if (!canonical.has_filename() && canonical.has_parent_path() &&
      canonical != canonical.root_path()) {
    canonical = canonical.parent_path();
  }
  return canonical;
}

// `inner` is `outer` or lies below it (component-wise).
bool IsWithin(const fs::path& inner, const fs::path& outer) {
  auto i = inner.begin();
  for (auto o = outer.begin(); o != outer.end(); ++o, ++i) {
    if (o->empty()) continue;  // Trailing separator.
    if (i == inner.end() || *i != *o) return false;
  }
  return true;
}

bool SameFile(const fs::path& a, const fs::path& b) {
  struct stat sa {
  }, sb{};
  if (::stat(a.c_str(), &sa) != 0 || ::stat(b.c_str(), &sb) != 0) return false;
  return sa.st_dev == sb.st_dev && sa.st_ino == sb.st_ino;
}

}  // namespace

bool CheckOutputNotInput(const NamedPath& output, const std::vector<NamedPath>& inputs,
                         std::string* why) {
  if (output.second.empty()) return true;
  const fs::path out = Canonical(output.second);
  for (const auto& [flag, path] : inputs) {
    if (path.empty()) continue;
    const fs::path in = Canonical(path);
    const std::string said = output.first + " " + output.second.string();
    if (out == in || SameFile(output.second, path)) {
      *why = said + " is the " + flag + " input; it would be overwritten";
      return false;
    }
    if (IsWithin(out, in)) {
      *why = said + " lies inside the " + flag + " input " + path.string();
      return false;
    }
    if (IsWithin(in, out)) {
      *why = said + " contains the " + flag + " input " + path.string();
      return false;
    }
  }
  return true;
}

bool CheckOutputs(const std::vector<NamedPath>& outputs, const std::vector<NamedPath>& inputs,
                  std::string* why) {
  for (size_t k = 0; k < outputs.size(); ++k) {
    if (!CheckOutputNotInput(outputs[k], inputs, why)) return false;
    for (size_t l = k + 1; l < outputs.size(); ++l) {
      if (outputs[k].second.empty() || outputs[l].second.empty()) continue;
      if (Canonical(outputs[k].second) == Canonical(outputs[l].second)) {
        *why = outputs[k].first + " and " + outputs[l].first + " name the same file " +
               outputs[k].second.string();
        return false;
      }
    }
  }
  return true;
}

}  // namespace rrslam
