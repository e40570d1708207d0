// Parsing of the whitespace-separated text lists used by the TUM benchmark
// (rgb.txt, depth.txt, groundtruth.txt, associations, trajectories).
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

namespace rrslam {

// Calls `fn(fields, line_number)` for every line of `text` that is neither
// blank nor a '#' comment. Fields are separated by spaces, tabs or commas
// (TUM's tools accept all three). Line numbers start at 1. `source` is unused
// here but documents the caller's file for errors raised inside `fn`.
void ForEachDataLine(
    std::string_view text, const std::string& source,
    const std::function<void(const std::vector<std::string_view>& fields, int line)>& fn);

// Parses a whole field as a finite double / integer. Throws DataError naming
// `source` and `line` otherwise.
double ParseDouble(std::string_view field, const std::string& source, int line);
long long ParseInteger(std::string_view field, const std::string& source, int line);

// Largest timestamp magnitude ParseTimestamp accepts, in seconds (the year
// 5138). TUM files give seconds since 1970 (1.3e9); a larger value is another
// unit (nanoseconds: 1.3e18, where a double no longer holds milliseconds) or
// a damaged file, and would print as hundreds of digits in "%f" outputs.
inline constexpr double kMaxTimestamp = 1e11;

// ParseDouble for a timestamp in seconds: also throws DataError "<source>
// line N: timestamp 1e+300 s is out of range ..." beyond kMaxTimestamp.
double ParseTimestamp(std::string_view field, const std::string& source, int line);

// `text` as one POSIX shell word: in single quotes, each embedded single quote
// written as '\'' (for command lines handed to std::system / popen).
std::string ShellQuote(std::string_view text);

// `value` as 16 lowercase hex digits (checksums and hashes in reports).
std::string Hex64(uint64_t value);

// One number through a printf format taking one double ("%g", "%.6f"), for
// messages and reports; at most 63 characters (a longer result is cut).
std::string Format(const char* format, double value);

// `text` with ASCII letters in lower case (file extensions, option values).
std::string AsciiLowercase(std::string text);

}  // namespace rrslam
