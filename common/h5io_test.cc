#include "common/h5io.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <vector>

#include "common/atomic_file.h"
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

std::vector<uint8_t> FileBytes(const std::filesystem::path& path) {
  const std::string text = ReadFileToString(path);
  return std::vector<uint8_t>(text.begin(), text.end());
}

// `what` of the DataError `fn` throws, or "no error".
template <typename Fn>
std::string DataErrorOf(Fn fn) {
  return testing::ErrorMessage<DataError>(fn);
}

TEST(H5io, OpensFileImagesInMemory) {
  testing::TempDir dir;
  {
    H5::H5File file = CreateH5File(dir / "t.h5");
    WriteFormatAttributes(file, kTest, "rrslam-test 0.1", {{"k", 10}});
    H5::Group group = file.createGroup("g");
    const std::vector<float> values = {1, 2, 3, 4, 5, 6};
    WriteH5Array<float>(group, "values", values, {3, 2});
  }
  const std::vector<uint8_t> bytes = FileBytes(dir / "t.h5");
  H5FormatInfo info;
  H5::H5File file = OpenH5FileImage(bytes, kTest, "mem.h5", &info);
  H5::H5File second = OpenH5FileImage(bytes, kTest, "other.h5");  // Two images at once.
  EXPECT_EQ(info.format, "rrslam.test");
  EXPECT_EQ(info.minor, 2);
  EXPECT_EQ(info.options["k"], 10);
  const auto values = ReadH5Array<float>(file.openGroup("g"), "values", "mem.h5");
  EXPECT_EQ(values[4], 5.0f);
  EXPECT_EQ(ReadH5Array<float>(second.openGroup("g"), "values", "other.h5").size(), 6u);

  // Errors name the image's name, as OpenH5File's name the path.
  EXPECT_NE(DataErrorOf([] { OpenH5FileImage({}, kTest, "mem.h5"); }).find("mem.h5: empty"),
            std::string::npos);
  const std::vector<uint8_t> text = {'p', 'l', 'a', 'i', 'n'};
  EXPECT_NE(
      DataErrorOf([&] { OpenH5FileImage(text, kTest, "mem.h5"); }).find("mem.h5: cannot open"),
      std::string::npos);
  const std::vector<uint8_t> truncated(bytes.begin(), bytes.begin() + bytes.size() / 2);
  EXPECT_NE(DataErrorOf([&] { OpenH5FileImage(truncated, kTest, "mem.h5"); }).find("mem.h5"),
            std::string::npos);
  FormatSpec future = kTest;
  future.major = 2;
  EXPECT_NE(DataErrorOf([&] { OpenH5FileImage(bytes, future, "mem.h5"); }).find("not supported"),
            std::string::npos);
  { H5::H5File bare = CreateH5File(dir / "bare.h5"); }
  EXPECT_NE(DataErrorOf([&] {
              OpenH5FileImage(FileBytes(dir / "bare.h5"), kTest, "mem.h5");
            }).find("mem.h5: HDF5 file without a 'format' attribute"),
            std::string::npos);
}

// Found by the features fuzzer: reading an attribute of several values into
// one string or double overran the stack (H5::Attribute::read writes every
// value); such attributes are now a DataError.
TEST(H5io, AttributesOfSeveralValuesAreDataErrors) {
  testing::TempDir dir;
  {
    H5::H5File file = CreateH5File(dir / "t.h5");
    const hsize_t three[1] = {3};
    H5::StrType type(H5::PredType::C_S1, H5T_VARIABLE);
    const char* formats[3] = {"rrslam.test", "b", "c"};
    file.createAttribute("format", type, H5::DataSpace(1, three)).write(type, formats);
    const double majors[3] = {1, 1, 1};
    file.createAttribute("format_major", H5::PredType::NATIVE_DOUBLE, H5::DataSpace(1, three))
        .write(H5::PredType::NATIVE_DOUBLE, majors);
  }
  H5::H5File file(dir.path() / "t.h5", H5F_ACC_RDONLY);
  EXPECT_NE(DataErrorOf([&] {
              ReadH5StringAttribute(file, "format", "t.h5");
            }).find("attribute format is not a single value"),
            std::string::npos);
  EXPECT_NE(DataErrorOf([&] {
              ReadH5ScalarAttribute(file, "format_major", "t.h5");
            }).find("attribute format_major is not a single value"),
            std::string::npos);
  EXPECT_THROW(OpenH5File(dir / "t.h5", kTest), DataError);
}

// Found by the features fuzzer: a dataset can declare any shape and hold no
// data (a fill value); reading it allocated the declared size (here 32 GB).
TEST(H5io, DatasetsLargerThanTheirStorageAreDataErrors) {
  testing::TempDir dir;
  {
    H5::H5File file = CreateH5File(dir / "t.h5");
    H5::Group group = file.createGroup("g");
    const hsize_t dims[2] = {hsize_t{1} << 30, 32};
    group.createDataSet("huge", H5::PredType::NATIVE_UINT8, H5::DataSpace(2, dims));
    const std::vector<uint8_t> small(64, 1);
    WriteH5Array<uint8_t>(group, "small", small, {2, 32});
    const std::vector<uint8_t> zeros(1 << 20, 0);
    WriteH5Array<uint8_t>(group, "zeros", zeros, {zeros.size()}, zeros.size());  // Deflated.
  }
  H5::H5File file(dir.path() / "t.h5", H5F_ACC_RDONLY);
  H5::Group group = file.openGroup("g");
  EXPECT_NE(DataErrorOf([&] {
              H5ArrayShape(group, "huge", "t.h5");
            }).find("t.h5: dataset huge declares 1073741824 x 32 elements"),
            std::string::npos);
  EXPECT_THROW(ReadH5Array<uint8_t>(group, "huge", "t.h5"), DataError);
  EXPECT_EQ(ReadH5Array<uint8_t>(group, "small", "t.h5").size(), 64u);
  EXPECT_EQ(ReadH5Array<uint8_t>(group, "zeros", "t.h5").size(), size_t{1} << 20);
}

}  // namespace
}  // namespace rrslam
