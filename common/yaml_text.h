// YAML text through OpenCV's parser (cv::FileStorage, OpenCV 4.6), with the
// guards its malformed input needs: it loops forever on some documents and
// lets std::length_error escape on others, instead of failing.
//
// The parser hangs when, after a top-level collection, a line starts left of
// it or a new document does not open with "---" (its parse() then waits on a
// '-' that is not "---"). Found by common/fuzz/settings_fuzzer.cc, e.g.
// "%YAML:1.0\n----=\n----\n" and "%YAML:1.0\n -%\n:#:-\n". Every YAML file
// rrslam reads (ORB-SLAM2 settings, DBoW2 YAML vocabularies) is one document
// holding a block map whose keys start at column 0, so text of another shape
// is rejected here, before the parser sees it.
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <string_view>

namespace rrslam {

// Throws DataError "<name>: line N: '<line>' <what> (<shape>)" unless `text`
// is one YAML document holding a block map at column 0: the first key line
// must not be indented or start with '-' (a top-level list), and no later
// line at column 0 may start with '-' or "..." (a list item, a second
// document, an end of document). One "---" line may open the document;
// blank lines, comments and %-directives are not looked at. `shape` says, in
// the caller's words, what the file should be (e.g. "settings are one YAML
// document holding a map of keys at column 0").
void CheckYamlIsOneMap(std::string_view text, const std::string& name, const std::string& shape);

// Deepest nesting of YAML collections ParseYamlText accepts. OpenCV's parser
// recurses once per level (flow '[' / '{', block indentation, and "a: b:" or
// "- -" on one line) and overflows an 8 MB stack at about 40000 levels, a
// thread's smaller stack far sooner; rrslam's files nest 4 levels at most.
inline constexpr int kMaxYamlNesting = 64;

// Throws DataError "<name>: line N: <what>" where OpenCV's parser would not
// fail but read the text wrongly or dangerously:
//   - "YAML nested deeper than 64 levels" when
//     the parser would be inside more than kMaxYamlNesting collections at
//     once on `text` (the top-level map is one; flow '[' and '{', block
//     sequences and maps, nested across lines or on one line as "a: b: 1"
//     and "- - 1"), and overflow its stack;
//   - "key 'k' is given twice": a map holds one key twice (OpenCV keeps the
//     first value and drops the second without a word);
//   - "integer 4294967316 does not fit in 32 bits": OpenCV stores an int,
//     which would wrap;
//   - "!!binary" data and "!<...>" tags, which the scan does not follow (no
//     rrslam file holds them).
// The text is scanned by following the parser's own rules (keys, quoted
// strings, comments, indentation) without recursing; where the text would
// stop the parser with a syntax error, what follows is not looked at.
void CheckYamlStructure(std::string_view text, const std::string& name);

// Parses `text` (held in memory) as YAML, after CheckYamlIsOneMap and
// CheckYamlStructure. Throws a one-line DataError
// "<name>: not a valid YAML file: line N: <what>" when OpenCV's parser
// fails, including on the exceptions other than cv::Exception it lets escape
// (std::length_error on an empty key in a flow map, "{ :a: 1 }"; found by
// stages/vocab/fuzz/vocab_yaml_fuzzer.cc).
cv::FileStorage ParseYamlText(const std::string& text, const std::string& name,
                              const std::string& shape);

// "line N: what" from an OpenCV YAML parser error, else its message on one line.
std::string YamlSyntaxError(const cv::Exception& e);

}  // namespace rrslam
