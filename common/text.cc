#include "common/text.h"

#include <charconv>
#include <cinttypes>
#include <cmath>
#include <cstdio>

#include "common/errors.h"

namespace rrslam {

void ForEachDataLine(
    std::string_view text, const std::string& /*source*/,
    const std::function<void(const std::vector<std::string_view>& fields, int line)>& fn) {
  std::vector<std::string_view> fields;
  int line_number = 0;
  size_t pos = 0;
  while (pos < text.size()) {
    size_t end = text.find('\n', pos);
    if (end == std::string_view::npos) end = text.size();
    std::string_view line = text.substr(pos, end - pos);
    pos = end + 1;
    ++line_number;
    fields.clear();
    size_t i = 0;
    auto is_sep = [](char c) { return c == ' ' || c == '\t' || c == ',' || c == '\r'; };
    while (i < line.size()) {
      while (i < line.size() && is_sep(line[i])) ++i;
      if (i >= line.size()) break;
      size_t j = i;
      while (j < line.size() && !is_sep(line[j])) ++j;
      fields.push_back(line.substr(i, j - i));
      i = j;
    }
    if (fields.empty() || fields[0].front() == '#') continue;
    fn(fields, line_number);
  }
}

double ParseDouble(std::string_view field, const std::string& source, int line) {
  double value = 0;
  const auto [ptr, ec] = std::from_chars(field.data(), field.data() + field.size(), value);
  if (ec != std::errc() || ptr != field.data() + field.size() || !std::isfinite(value)) {
    throw DataError(source + " line " + std::to_string(line) + ": '" + std::string(field) +
                    "' is not a number");
  }
  return value;
}

double ParseTimestamp(std::string_view field, const std::string& source, int line) {
  const double value = ParseDouble(field, source, line);
  if (std::fabs(value) > kMaxTimestamp) {
    throw DataError(source + " line " + std::to_string(line) + ": timestamp " +
                    Format("%g", value) + " s is out of range (seconds since 1970 expected, " +
                    "at most " + Format("%g", kMaxTimestamp) + ")");
  }
  return value;
}

long long ParseInteger(std::string_view field, const std::string& source, int line) {
  long long value = 0;
  const auto [ptr, ec] = std::from_chars(field.data(), field.data() + field.size(), value);
  if (ec != std::errc() || ptr != field.data() + field.size()) {
    throw DataError(source + " line " + std::to_string(line) + ": '" + std::string(field) +
                    "' is not an integer");
  }
  return value;
}

std::string ShellQuote(std::string_view text) {
  std::string quoted(1, '\'');
  for (const char c : text) {
    if (c == '\'') {
      quoted += "'\\''";
    } else {
      quoted += c;
    }
  }
  quoted += '\'';
  return quoted;
}

std::string Hex64(uint64_t value) {
  char buffer[17];
  std::snprintf(buffer, sizeof(buffer), "%016" PRIx64, value);
  return buffer;
}

std::string Format(const char* format, double value) {
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), format, value);
  return buffer;
}

std::string AsciiLowercase(std::string text) {
  for (char& c : text) {
    if (c >= 'A' && c <= 'Z') c = static_cast<char>(c - 'A' + 'a');
  }
  return text;
}

}  // namespace rrslam
