#include "common/text.h"

#include <gtest/gtest.h>

#include <cstdio>

#include "common/errors.h"

namespace rrslam {
namespace {

TEST(ForEachDataLine, SkipsCommentsAndBlankLinesAndSplitsFields) {
  std::vector<std::vector<std::string>> rows;
  std::vector<int> lines;
  ForEachDataLine("# header\n\n  a b\tc\n#x\nd,e \r\nf", "t", [&](const auto& fields, int line) {
    rows.emplace_back(fields.begin(), fields.end());
    lines.push_back(line);
  });
  ASSERT_EQ(rows.size(), 3u);
  EXPECT_EQ(rows[0], (std::vector<std::string>{"a", "b", "c"}));
  EXPECT_EQ(rows[1], (std::vector<std::string>{"d", "e"}));
  EXPECT_EQ(rows[2], (std::vector<std::string>{"f"}));
  EXPECT_EQ(lines, (std::vector<int>{3, 5, 6}));
}

TEST(ParseNumbers, StrictWholeField) {
  EXPECT_DOUBLE_EQ(ParseDouble("1305031453.359684", "t", 1), 1305031453.359684);
  EXPECT_DOUBLE_EQ(ParseDouble("-1e-3", "t", 1), -1e-3);
  EXPECT_THROW(ParseDouble("1.5x", "t", 1), DataError);
  EXPECT_THROW(ParseDouble("", "t", 1), DataError);
  EXPECT_THROW(ParseDouble("inf", "t", 1), DataError);
  EXPECT_EQ(ParseInteger("-42", "t", 1), -42);
  EXPECT_THROW(ParseInteger("4.2", "t", 1), DataError);
  try {
    ParseDouble("zz", "list.txt", 7);
    FAIL();
  } catch (const DataError& e) {
    EXPECT_STREQ(e.what(), "list.txt line 7: 'zz' is not a number");
  }
}

// Issue 36: a timestamp of 1e300 was printed as a 300-digit number.
TEST(ParseNumbers, TimestampsAreSecondsWithinRange) {
  EXPECT_DOUBLE_EQ(ParseTimestamp("1305031453.359684", "t", 1), 1305031453.359684);
  EXPECT_DOUBLE_EQ(ParseTimestamp("-1e11", "t", 1), -1e11);
  try {
    ParseTimestamp("1e300", "rgb.txt", 4);
    FAIL();
  } catch (const DataError& e) {
    EXPECT_STREQ(e.what(),
                 "rgb.txt line 4: timestamp 1e+300 s is out of range (seconds since 1970 "
                 "expected, at most 1e+11)");
  }
  EXPECT_THROW(ParseTimestamp("1305031453359684000", "t", 1), DataError);  // Nanoseconds.
}

TEST(Format, OneNumberThroughAPrintfFormat) {
  EXPECT_EQ(Format("%g", 0.5), "0.5");
  EXPECT_EQ(Format("%.3f", 2.0), "2.000");
  EXPECT_EQ(Format("%f", 1e300).size(), 63u);  // Cut to the buffer, never overflowing it.
}

TEST(ShellQuoteTest, QuotesOneWordThroughTheShell) {
  EXPECT_EQ(ShellQuote("a b"), "'a b'");
  EXPECT_EQ(ShellQuote("it's"), "'it'\\''s'");
  // The shell gives back the exact text, spaces, quotes and $ included.
  const std::string text = "x 'y' $HOME \"z\"";
  FILE* pipe = popen(("printf %s " + ShellQuote(text)).c_str(), "r");
  ASSERT_NE(pipe, nullptr);
  char buffer[128] = {};
  const size_t n = fread(buffer, 1, sizeof(buffer) - 1, pipe);
  pclose(pipe);
  EXPECT_EQ(std::string(buffer, n), text);
}

}  // namespace
}  // namespace rrslam
