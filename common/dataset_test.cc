#include "common/dataset.h"

#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "common/atomic_file.h"
#include "common/errors.h"
#include "common/testing.h"

namespace rrslam {
namespace {
namespace fs = std::filesystem;

TEST(AssociateTimestamps, GreedyBySmallestDifferenceEachStampOnce) {
  // 1.00 is closest to 1.005 (0.005) and 1.011 (0.011); 1.01 is closest to 1.011.
  const std::vector<double> a = {1.00, 1.01, 2.0};
  const std::vector<double> b = {1.005, 1.011, 2.5};
  const auto m = AssociateTimestamps(a, b, 0.02);
  ASSERT_EQ(m.size(), 2u);
  EXPECT_EQ(m[0], std::make_pair(size_t(0), size_t(0)));
  EXPECT_EQ(m[1], std::make_pair(size_t(1), size_t(1)));
}

TEST(AssociateTimestamps, GreedyTakesGlobalBestFirst) {
  // b=1.012 is nearest to a=1.01 (0.002); a=1.00 must then take b=1.019 (0.019),
  // not b=1.012 even though it scans first.
  const auto m = AssociateTimestamps({1.00, 1.01}, {1.012, 1.019}, 0.02);
  ASSERT_EQ(m.size(), 2u);
  EXPECT_EQ(m[0], std::make_pair(size_t(0), size_t(1)));
  EXPECT_EQ(m[1], std::make_pair(size_t(1), size_t(0)));
}

TEST(AssociateTimestamps, MaxDifferenceIsStrictAndOffsetApplies) {
  EXPECT_TRUE(AssociateTimestamps({1.0}, {1.5}, 0.5).empty());
  EXPECT_EQ(AssociateTimestamps({1.0}, {1.25}, 0.5).size(), 1u);
  EXPECT_EQ(AssociateTimestamps({1.0}, {0.5}, 0.02, 0.5).size(), 1u);
  EXPECT_TRUE(AssociateTimestamps({1.0}, {0.5}, 0.02, 0.0).empty());
}

TEST(RgbdSequence, OpensTumFr1DeskSnippet) {
  RRSLAM_REQUIRE_SHARED_DATA(data);
  const RgbdSequence seq = RgbdSequence::Open(data / "tum" / "fr1_desk");
  EXPECT_EQ(seq.size(), 9u);
  // Same pairs as ORB-SLAM2's associations file for the first frames.
  EXPECT_DOUBLE_EQ(seq.frame(0).rgb_timestamp, 1305031453.359684);
  EXPECT_DOUBLE_EQ(seq.frame(0).depth_timestamp, 1305031453.374112);
  EXPECT_DOUBLE_EQ(seq.frame(1).depth_timestamp, 1305031453.404816);
  ASSERT_TRUE(seq.groundtruth().has_value());
  EXPECT_EQ(seq.groundtruth()->size(), 2335u);
  const cv::Mat gray = seq.LoadGray(0);
  EXPECT_EQ(gray.type(), CV_8UC1);
  EXPECT_EQ(gray.cols, 640);
  const cv::Mat depth = seq.LoadDepthRaw(0);
  EXPECT_EQ(depth.type(), CV_16UC1);
  const cv::Mat metres = seq.LoadDepthMetres(0, 5000.0);
  EXPECT_EQ(metres.type(), CV_32FC1);
  int valid = cv::countNonZero((metres > 0.3f) & (metres < 10.0f));
  EXPECT_GT(valid, 640 * 480 / 2);
}

TEST(RgbdSequence, FullListsPairLikeOrbSlam2Associations) {
  RRSLAM_REQUIRE_SHARED_DATA(data);
  const fs::path dir = data / "tum" / "fr1_desk";
  const auto rgb = ReadTimestampList(dir / "rgb_full.txt");
  const auto depth = ReadTimestampList(dir / "depth_full.txt");
  std::vector<double> ra, da;
  for (const auto& e : rgb) ra.push_back(e.first);
  for (const auto& e : depth) da.push_back(e.first);
  const auto matches = AssociateTimestamps(ra, da, 0.02);
  // associations_orbslam2_full.txt was made by TUM's associate.py with the defaults.
  const std::string text = ReadFileToString(dir / "associations_orbslam2_full.txt");
  std::vector<std::pair<double, double>> expected;
  std::istringstream in(text);
  double a, b;
  std::string pa, pb;
  while (in >> a >> pa >> b >> pb) expected.emplace_back(a, b);
  ASSERT_EQ(matches.size(), expected.size());
  for (size_t k = 0; k < matches.size(); ++k) {
    EXPECT_DOUBLE_EQ(ra[matches[k].first], expected[k].first);
    EXPECT_DOUBLE_EQ(da[matches[k].second], expected[k].second);
  }
}

TEST(RgbdSequence, ReadsAssociationsFileAndSevenScenes) {
  RRSLAM_REQUIRE_SHARED_DATA(data);
  SequenceOptions options;
  options.associations = "associations.txt";
  const RgbdSequence seq = RgbdSequence::Open(data / "7scenes-kitchen", options);
  EXPECT_EQ(seq.size(), 1000u);
  EXPECT_EQ(seq.LoadColor(0).type(), CV_8UC3);  // JPEG colour.
}

class BadSequence : public ::testing::Test {
 protected:
  void SetUp() override {
    fs::create_directories(dir_ / "seq" / "rgb");
    fs::create_directories(dir_ / "seq" / "depth");
    cv::imwrite((dir_ / "seq" / "rgb" / "1.png").string(),
                cv::Mat(48, 64, CV_8UC3, cv::Scalar(1, 2, 3)));
    cv::imwrite((dir_ / "seq" / "depth" / "1.png").string(),
                cv::Mat(48, 64, CV_16UC1, cv::Scalar(5000)));
    testing::WriteTextFile(dir_ / "seq" / "rgb.txt", "# rgb\n1.0 rgb/1.png\n");
    testing::WriteTextFile(dir_ / "seq" / "depth.txt", "# depth\n1.001 depth/1.png\n");
  }
  fs::path seq() const { return dir_ / "seq"; }
  testing::TempDir dir_;
};

TEST_F(BadSequence, ValidBaseline) {
  const RgbdSequence s = RgbdSequence::Open(seq());
  ASSERT_EQ(s.size(), 1u);
  EXPECT_EQ(s.LoadDepthRaw(0).at<uint16_t>(0, 0), 5000);
  EXPECT_FALSE(s.groundtruth().has_value());
}

TEST_F(BadSequence, MissingFolderOrLists) {
  EXPECT_THROW(RgbdSequence::Open(seq() / "nope"), NoInputError);
  fs::remove(seq() / "depth.txt");
  EXPECT_THROW(RgbdSequence::Open(seq()), NoInputError);
}

TEST_F(BadSequence, EmptyList) {
  testing::WriteTextFile(seq() / "rgb.txt", "# nothing\n");
  EXPECT_THROW(RgbdSequence::Open(seq()), DataError);
}

TEST_F(BadSequence, MalformedListLine) {
  testing::WriteTextFile(seq() / "rgb.txt", "1.0\n");
  EXPECT_THROW(RgbdSequence::Open(seq()), DataError);
  testing::WriteTextFile(seq() / "rgb.txt", "abc rgb/1.png\n");
  EXPECT_THROW(RgbdSequence::Open(seq()), DataError);
}

TEST_F(BadSequence, ListNamesAFolder) {
  testing::WriteTextFile(seq() / "rgb.txt", "1.0 rgb\n");
  try {
    RgbdSequence::Open(seq());
    FAIL();
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.what()).find("listed image is a folder"), std::string::npos)
        << e.what();
  }
}

TEST_F(BadSequence, ListNamesAbsentImage) {
  testing::WriteTextFile(seq() / "rgb.txt", "1.0 rgb/missing.png\n");
  try {
    RgbdSequence::Open(seq());
    FAIL();
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.what()).find("missing.png"), std::string::npos) << e.what();
  }
}

TEST_F(BadSequence, NoPairsWithinMaxDifference) {
  testing::WriteTextFile(seq() / "depth.txt", "1.5 depth/1.png\n");
  EXPECT_THROW(RgbdSequence::Open(seq()), DataError);
}

TEST_F(BadSequence, EightBitDepthAndSizeMismatch) {
  cv::imwrite((seq() / "depth" / "1.png").string(), cv::Mat(48, 64, CV_8UC1, cv::Scalar(5)));
  const RgbdSequence s = RgbdSequence::Open(seq());
  try {
    s.LoadDepthRaw(0);
    FAIL();
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.what()).find("16-bit"), std::string::npos) << e.what();
  }
  const cv::Mat rgb(48, 64, CV_8UC3), depth(24, 32, CV_16UC1);
  EXPECT_THROW(CheckSameSize(rgb, depth, "d.png"), DataError);
}

// Images larger than the settings' Camera.width x Camera.height are refused
// (from their headers) by every Load*: they would be tracked with the wrong
// calibration. The settings' size itself, or no size, reads.
TEST_F(BadSequence, ImageLargerThanTheGivenSize) {
  SequenceOptions options;
  options.max_image_size = {64, 40, "Camera.width x Camera.height of s.yaml"};
  const RgbdSequence s = RgbdSequence::Open(seq(), options);
  const std::string expected =
      ": image is 64x48, larger than 64x40 (Camera.width x "
      "Camera.height of s.yaml)";
  for (int load = 0; load < 4; ++load) {
    try {
      if (load == 0) s.LoadGray(0);
      if (load == 1) s.LoadColor(0);
      if (load == 2) s.LoadDepthRaw(0);
      if (load == 3) s.LoadDepthMetres(0, 5000);
      ADD_FAILURE() << "load " << load;
    } catch (const DataError& e) {
      const std::string message = e.what();
      EXPECT_NE(message.find((load < 2 ? "rgb/1.png" : "depth/1.png") + expected),
                std::string::npos)
          << message;
    }
  }
  EXPECT_THROW(LoadGrayImage(seq() / "rgb" / "1.png", options.max_image_size), DataError);
  options.max_image_size = {64, 48, "s.yaml"};
  EXPECT_EQ(RgbdSequence::Open(seq(), options).LoadGray(0).size(), cv::Size(64, 48));
  options.max_image_size = {};
  EXPECT_EQ(RgbdSequence::Open(seq(), options).LoadDepthRaw(0).size(), cv::Size(64, 48));
}

TEST_F(BadSequence, UnreadableImage) {
  testing::WriteTextFile(seq() / "rgb" / "1.png", "not a png");
  const RgbdSequence s = RgbdSequence::Open(seq());
  EXPECT_THROW(s.LoadGray(0), DataError);
}

TEST(TimestampList, ParsesTextAsTheFileReaderDoes) {
  const auto list =
      ParseTimestampList("# rgb\n1.5 rgb/a.png\n\n2.25,rgb/b.png extra\r\n", "rgb.txt");
  ASSERT_EQ(list.size(), 2u);
  EXPECT_EQ(list[0], std::make_pair(1.5, std::string("rgb/a.png")));
  EXPECT_EQ(list[1], std::make_pair(2.25, std::string("rgb/b.png")));
  EXPECT_TRUE(ParseTimestampList("", "rgb.txt").empty());
  try {
    ParseTimestampList("1.0 a.png\n2.0\n", "mem.txt");
    FAIL();
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.what()).find("mem.txt line 2"), std::string::npos) << e.what();
  }
  EXPECT_THROW(ParseTimestampList("inf a.png\n", "rgb.txt"), DataError);
  testing::TempDir dir;
  testing::WriteTextFile(dir / "rgb.txt", "# rgb\n1.5 rgb/a.png\n");
  EXPECT_EQ(ReadTimestampList(dir / "rgb.txt"), ParseTimestampList("1.5 rgb/a.png", "x"));
}

TEST(Associations, ParsesTextRelativeToTheSequence) {
  const auto frames =
      ParseAssociations("# a\n1.0 rgb/1.png 1.01 depth/1.png\n2.0\trgb/2.png\t2.02\tdepth/2.png\n",
                        "seq", "assoc.txt");
  ASSERT_EQ(frames.size(), 2u);
  EXPECT_EQ(frames[1].rgb_timestamp, 2.0);
  EXPECT_EQ(frames[1].depth_timestamp, 2.02);
  EXPECT_EQ(frames[1].rgb_path, fs::path("seq") / "rgb/2.png");
  EXPECT_EQ(frames[1].depth_path, fs::path("seq") / "depth/2.png");
  try {
    ParseAssociations("1.0 rgb/1.png 1.01\n", "seq", "assoc.txt");
    FAIL();
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.what()).find("assoc.txt line 1"), std::string::npos) << e.what();
  }
  EXPECT_THROW(ParseAssociations("1.0 rgb/1.png x depth/1.png\n", "seq", "a.txt"), DataError);
}

}  // namespace
}  // namespace rrslam
