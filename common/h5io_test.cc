#include "common/h5io.h"

#include <gtest/gtest.h>

#include "common/testing.h"

namespace rrslam {
namespace {

constexpr FormatSpec kTest = {"rrslam.test", "", 1, 2};

TEST(H5io, RootAttributesArraysAndStringsRoundTrip) {
  testing::TempDir dir;
  {
    H5::H5File file = CreateH5File(dir / "t.h5");
    WriteFormatAttributes(file, kTest, "rrslam-test 0.1", {{"k", 10}, {"name", "x"}});
    H5::Group group = file.createGroup("g");
    const std::vector<float> values = {1, 2, 3, 4, 5, 6};
    WriteH5Array<float>(group, "values", values, {3, 2});
    const std::vector<uint64_t> big(1000, 7);
    WriteH5Array<uint64_t>(group, "big", big, {1000}, 128);
    WriteH5StringArray(group, "names", {"a", "", "ccc"});
    WriteH5StringAttribute(group, "note", "hello");
  }
  H5FormatInfo info;
  H5::H5File file = OpenH5File(dir / "t.h5", kTest, &info);
  EXPECT_EQ(info.format, "rrslam.test");
  EXPECT_EQ(info.major, 1);
  EXPECT_EQ(info.minor, 2);
  EXPECT_EQ(info.producer, "rrslam-test 0.1");
  EXPECT_EQ(info.options["k"], 10);
  H5::Group group = file.openGroup("g");
  std::vector<hsize_t> dims;
  const auto values = ReadH5Array<float>(group, "values", "t.h5", &dims, 2);
  EXPECT_EQ(dims, (std::vector<hsize_t>{3, 2}));
  EXPECT_EQ(values[5], 6.0f);
  EXPECT_THROW(ReadH5Array<float>(group, "values", "t.h5", nullptr, 1), DataError);
  const auto as_double = ReadH5Array<double>(group, "values", "t.h5");  // Converted.
  EXPECT_EQ(as_double[2], 3.0);
  EXPECT_EQ(ReadH5Array<uint64_t>(group, "big", "t.h5").size(), 1000u);
  EXPECT_EQ(ReadH5StringArray(group, "names", "t.h5"), (std::vector<std::string>{"a", "", "ccc"}));
  EXPECT_EQ(ReadH5StringAttribute(group, "note", "t.h5"), "hello");
  EXPECT_THROW(ReadH5Array<float>(group, "absent", "t.h5"), DataError);
}

TEST(H5io, OpenRejectsWrongFiles) {
  testing::TempDir dir;
  EXPECT_THROW(OpenH5File(dir / "absent.h5", kTest), NoInputError);
  testing::WriteTextFile(dir / "text.h5", "plain text");
  EXPECT_THROW(OpenH5File(dir / "text.h5", kTest), DataError);
  { H5::H5File bare = CreateH5File(dir / "bare.h5"); }
  EXPECT_THROW(OpenH5File(dir / "bare.h5", kTest), DataError);
  {
    H5::H5File file = CreateH5File(dir / "future.h5");
    FormatSpec future = kTest;
    future.major = 2;
    WriteFormatAttributes(file, future, "p", {});
  }
  EXPECT_THROW(OpenH5File(dir / "future.h5", kTest), DataError);
  {
    H5::H5File file = CreateH5File(dir / "newer_minor.h5");
    FormatSpec newer = kTest;
    newer.minor = 7;
    WriteFormatAttributes(file, newer, "p", {});
  }
  H5FormatInfo info;
  EXPECT_NO_THROW(OpenH5File(dir / "newer_minor.h5", kTest, &info));
  EXPECT_EQ(info.minor, 7);
}

TEST(H5io, CreateInMissingFolderIsCantCreate) {
  testing::TempDir dir;
  EXPECT_THROW(CreateH5File(dir / "missing" / "t.h5"), CantCreateError);
}

}  // namespace
}  // namespace rrslam
