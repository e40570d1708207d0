#include "common/text.h"

#include <gtest/gtest.h>

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

}  // namespace
}  // namespace rrslam
