#include "common/yaml_text.h"

#include <algorithm>
#include <exception>
#include <regex>

#include "common/errors.h"

namespace rrslam {

void CheckYamlIsOneMap(std::string_view text, const std::string& name, const std::string& shape) {
  bool first = true;    // No key line yet.
  bool opened = false;  // The "---" marker was seen.
  int line = 0;
  for (size_t begin = 0; begin < text.size();) {
    size_t end = text.find('\n', begin);
    if (end == std::string_view::npos) end = text.size();
    std::string_view l = text.substr(begin, end - begin);
    begin = end + 1;
    ++line;
    while (!l.empty() && (l.back() == '\r' || l.back() == ' ')) l.remove_suffix(1);
    const size_t content = l.find_first_not_of(' ');
    if (content == std::string_view::npos || l[content] == '#' || l.front() == '%') continue;
    auto fail = [&](const std::string& what) {
      throw DataError(name + ": line " + std::to_string(line) + ": '" +
                      std::string(l.substr(0, 24)) + "' " + what + " (" + shape + ")");
    };
    if (first && !opened && l.substr(0, 3) == "---" &&
        (l.size() == 3 || l.find_first_not_of(' ', 3) == std::string_view::npos ||
         l[l.find_first_not_of(' ', 3)] == '#')) {
      opened = true;  // The document's opening marker.
      continue;
    }
    if (first && content > 0) fail("is indented");
    if (l.front() == '-') fail("starts with '-' (a list or a second document)");
    if (l.substr(0, 3) == "...") fail("ends the document");
    first = false;
  }
}

cv::FileStorage ParseYamlText(const std::string& text, const std::string& name,
                              const std::string& shape) {
  CheckYamlIsOneMap(text, name, shape);
  cv::FileStorage fs;
  try {
    fs.open(text, cv::FileStorage::READ | cv::FileStorage::MEMORY | cv::FileStorage::FORMAT_YAML);
  } catch (const cv::Exception& e) {
    throw DataError(name + ": not a valid YAML file: " + YamlSyntaxError(e));
  } catch (const std::exception& e) {
    // OpenCV's parser lets a std::length_error escape on "{ :a: 1 }".
    throw DataError(name + ": not a valid YAML file (" + e.what() + ")");
  }
  if (!fs.isOpened()) throw DataError(name + ": not a valid YAML file");
  return fs;
}

// OpenCV 4 formats "<file>(<line>): <what>" and passes it as the exception's
// function name (FileStorage::Impl::parseError swaps its arguments), with the
// parser function's name as the message; look in both.
std::string YamlSyntaxError(const cv::Exception& e) {
  static const std::regex kLine(R"(\((\d+)\): ([^\n]*))");
  for (const std::string* text : {&e.func, &e.err}) {
    std::smatch m;
    if (std::regex_search(*text, m, kLine)) return "line " + m[1].str() + ": " + m[2].str();
  }
  std::string text = e.err;
  std::replace(text.begin(), text.end(), '\n', ' ');
  return text;
}

}  // namespace rrslam
