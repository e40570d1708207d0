#include "common/json_text.h"

#include <gtest/gtest.h>

#include <string>

namespace rrslam {
namespace {

TEST(JsonText, ValidUtf8IsKeptAsItIs) {
  for (const std::string s : {"", "plain/path.txt", "caf\xc3\xa9", "\xe2\x82\xac \xf0\x9f\x98\x80",
                              "a\"b\\c", "\"only at the start", "tab\tand\nnewline"}) {
    EXPECT_TRUE(IsValidUtf8(s)) << s;
    EXPECT_EQ(JsonString(s), s);
    EXPECT_EQ(UnquoteJsonString(JsonString(s)), s);
  }
}

TEST(JsonText, InvalidBytesAreQuotedReversibly) {
  EXPECT_FALSE(IsValidUtf8("caf\xe9"));
  EXPECT_EQ(JsonString("/tmp/caf\xe9/gt.txt"), "\"/tmp/caf\\351/gt.txt\"");
  // Overlong forms, surrogates, code points above U+10FFFF, truncated
  // sequences and stray continuation bytes are not UTF-8 (nlohmann refuses
  // them too).
  for (const std::string& s :
       {std::string("\xc0\xaf"), std::string("\xed\xa0\x80"), std::string("\xf4\x90\x80\x80"),
        std::string("ab\xe2\x82"), std::string("\x80"), std::string("x\xff\"y\\z\xc3\xa9"),
        std::string("\"caf\\351\""), std::string("\"\""), std::string("a\0b\xfe", 4)}) {
    const std::string quoted = JsonString(s);
    EXPECT_TRUE(IsValidUtf8(quoted)) << quoted;
    EXPECT_EQ(UnquoteJsonString(quoted), s) << quoted;
  }
  // Valid characters stay readable inside the quotes.
  EXPECT_EQ(JsonString("\xc3\xa9\xe9"), "\"\xc3\xa9\\351\"");
  // Every byte value round-trips.
  std::string all;
  for (int b = 0; b < 256; ++b) all += static_cast<char>(b);
  EXPECT_EQ(UnquoteJsonString(JsonString(all)), all);
}

TEST(JsonText, PathsRoundTrip) {
  const std::filesystem::path latin1 = "/data/caf\xe9/rgb.txt";
  EXPECT_EQ(PathFromJson(PathToJson(latin1)), latin1);
  EXPECT_EQ(PathToJson("/data/x"), "/data/x");
}

TEST(JsonText, DumpJsonWritesStringsThatAreNotUtf8) {
  nlohmann::ordered_json j = {{"sequence", "/data/caf\xe9"},
                              {"list", {"ok", "b\xe9"}},
                              {"nested", {{"k\xe9y", 1}, {"z", "\xc3\xa9"}}}};
  EXPECT_THROW((void)j.dump(), nlohmann::json::type_error);  // What the writers did.
  const std::string text = DumpJson(j, 2);
  const auto parsed = nlohmann::ordered_json::parse(text);
  EXPECT_EQ(PathFromJson(parsed["sequence"].get<std::string>()), "/data/caf\xe9");
  EXPECT_EQ(UnquoteJsonString(parsed["list"][1].get<std::string>()), "b\xe9");
  EXPECT_EQ(parsed["list"][0], "ok");
  EXPECT_EQ(parsed["nested"]["z"], "\xc3\xa9");
  ASSERT_TRUE(parsed["nested"].contains("\"k\\351y\""));
  // Key order is kept.
  EXPECT_EQ(parsed.begin().key(), "sequence");
  // Without such strings: exactly dump().
  const nlohmann::json plain = {{"a", 1}, {"b", "\xc3\xa9"}};
  EXPECT_EQ(DumpJson(plain), plain.dump());
  EXPECT_EQ(DumpJson(plain, 2), plain.dump(2));
}

}  // namespace
}  // namespace rrslam
