#include "stages/render/octomap/occupancy_grid.h"

#include <gtest/gtest.h>
#include <octomap/OcTree.h>

#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "common/atomic_file.h"
#include "common/testing.h"
#include "stages/render/octomap/box_room_test_util.h"

namespace rrslam {
namespace {

class BoxRoomGrid : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    const testing::BoxRoom room;
    std::vector<Rigid3d> poses;
    for (int k = 0; k < 12; ++k) poses.push_back(room.CameraPose(k, 12));
    IntegrationStats stats;
    tree_ = IntegrateDepth(
                DepthIntegrationOptions{}, room.camera, poses,
                [&](size_t i) { return room.Depth(poses[i]); }, &stats)
                .release();
    grid_ = new OccupancyGrid(ProjectOctree(*tree_, 0.1, 1.5));
  }
  static void TearDownTestSuite() {
    delete grid_;
    delete tree_;
  }

  // The cell at a floor point (x, y).
  static int8_t At(double x, double y) {
    int cx = 0, cy = 0;
    if (!grid_->CellOf({x, y}, &cx, &cy)) return -2;
    return grid_->at(cx, cy);
  }

  static octomap::OcTree* tree_;
  static OccupancyGrid* grid_;
};
octomap::OcTree* BoxRoomGrid::tree_ = nullptr;
OccupancyGrid* BoxRoomGrid::grid_ = nullptr;

TEST_F(BoxRoomGrid, EmptyFloorIsFreeAndTheCamerasStandOnIt) {
  int free = 0, total = 0;
  for (double x = -1.7; x <= 1.7; x += 0.1) {
    for (double y = -1.2; y <= 1.2; y += 0.1) {
      const bool on_table = x > 0.7 && x < 1.5 && y > -0.5 && y < 0.5;
      if (on_table) continue;
      ++total;
      if (At(x, y) == kCellFree) ++free;
    }
  }
  EXPECT_GE(free, total * 98 / 100) << free << " of " << total;
  EXPECT_EQ(At(0.01, 0.01), kCellFree);
}

TEST_F(BoxRoomGrid, WallsAndTableAreOccupied) {
  int occupied = 0, total = 0;
  const double e = 0.02;  // Inside the wall voxel.
  for (double t = -1.2; t <= 1.2; t += 0.1) {
    for (const Eigen::Vector2d& p : {Eigen::Vector2d(-2 + e, t), Eigen::Vector2d(2 - e, t)}) {
      ++total;
      if (At(p.x(), p.y()) == kCellOccupied ||
          At(p.x() + (p.x() < 0 ? -0.05 : 0.05), p.y()) == kCellOccupied) {
        ++occupied;
      }
    }
  }
  EXPECT_GE(occupied, total * 95 / 100) << occupied << " of " << total;
  for (double x = 0.85; x < 1.4; x += 0.1) {
    for (double y = -0.35; y < 0.4; y += 0.1) EXPECT_EQ(At(x, y), kCellOccupied) << x << " " << y;
  }
}

TEST_F(BoxRoomGrid, NothingIsKnownBeyondTheWalls) {
  EXPECT_LE(grid_->origin.x(), -2.0);
  EXPECT_GE(grid_->origin.x(), -2.1);
  // Nothing lies beyond the walls: outside the grid or unknown.
  for (double y = -1.0; y <= 1.0; y += 0.25) {
    const int8_t cell = At(2.2, y);
    EXPECT_TRUE(cell == -2 || cell == kCellUnknown) << y;
  }
}

TEST_F(BoxRoomGrid, ABandAboveTheTableLeavesItFree) {
  const OccupancyGrid high = ProjectOctree(*tree_, 0.9, 1.5);
  int x = 0, y = 0;
  ASSERT_TRUE(high.CellOf({1.1, 0.0}, &x, &y));
  EXPECT_EQ(high.at(x, y), kCellFree);
}

// The files as ROS's map_server reads them: the PGM through OpenCV's own
// reader, each pixel's occupancy (255 - value) / 255 against the YAML's
// thresholds in trinary mode, and the origin as the lower-left pixel.
TEST_F(BoxRoomGrid, MapServerFilesReadBackAsTheGrid) {
  testing::TempDir dir;
  WriteFileAtomically(dir.path() / "map.pgm", MapServerPgm(*grid_));
  const std::string yaml = MapServerYaml(*grid_, "map.pgm", {"made by a test"});
  EXPECT_EQ(yaml.rfind("# made by a test\nimage: map.pgm\nmode: trinary\n", 0), 0u) << yaml;
  double occupied_thresh = 0, free_thresh = 0, resolution = 0, ox = 0, oy = 0;
  std::istringstream lines(yaml);
  for (std::string line; std::getline(lines, line);) {
    std::sscanf(line.c_str(), "occupied_thresh: %lf", &occupied_thresh);
    std::sscanf(line.c_str(), "free_thresh: %lf", &free_thresh);
    std::sscanf(line.c_str(), "resolution: %lf", &resolution);
    std::sscanf(line.c_str(), "origin: [%lf, %lf", &ox, &oy);
  }
  EXPECT_DOUBLE_EQ(resolution, grid_->resolution);
  EXPECT_NEAR(ox, grid_->origin.x(), 1e-6);
  EXPECT_NEAR(oy, grid_->origin.y(), 1e-6);
  const cv::Mat pgm = cv::imread((dir.path() / "map.pgm").string(), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(pgm.type(), CV_8UC1);
  ASSERT_EQ(pgm.cols, grid_->width);
  ASSERT_EQ(pgm.rows, grid_->height);
  size_t mismatched = 0;
  for (int row = 0; row < pgm.rows; ++row) {
    for (int x = 0; x < pgm.cols; ++x) {
      const double occupancy = (255 - pgm.at<uint8_t>(row, x)) / 255.0;
      const int8_t read = occupancy > occupied_thresh ? kCellOccupied
                          : occupancy < free_thresh   ? kCellFree
                                                      : kCellUnknown;
      if (read != grid_->at(x, pgm.rows - 1 - row)) ++mismatched;
    }
  }
  EXPECT_EQ(mismatched, 0u);
}

TEST_F(BoxRoomGrid, PictureDrawsTheTrajectoryOverTheGrid) {
  const std::vector<Eigen::Vector2d> trajectory = {{-1, 0}, {1, 0}};
  const cv::Mat picture = GridPicture(*grid_, trajectory, 4);
  ASSERT_EQ(picture.type(), CV_8UC3);
  EXPECT_EQ(picture.cols, std::max(grid_->width * 4, 420));
  EXPECT_GT(picture.rows, grid_->height * 4);  // The legend below.
  // The trajectory's middle, (0, 0), is blue.
  const int px = static_cast<int>((0 - grid_->origin.x()) / grid_->resolution * 4);
  const int py =
      static_cast<int>((grid_->height - (0 - grid_->origin.y()) / grid_->resolution) * 4);
  const cv::Vec3b bgr = picture.at<cv::Vec3b>(py, px);
  EXPECT_GT(bgr[0], 150);
  EXPECT_LT(bgr[2], 100);
}

TEST(GridOptions, Checks) {
  GridOptions o;
  std::string why;
  EXPECT_FALSE(o.Check(&why));
  o.input.map = "m.rrm";
  o.input.sequence = "seq";
  o.out = "map.yaml";
  EXPECT_TRUE(o.Check(&why)) << why;
  EXPECT_EQ(o.PgmPath(), "map.pgm");
  EXPECT_EQ(o.ImagePath(), "map.png");
  GridOptions bad = o;
  bad.out = "map.pgm";
  EXPECT_FALSE(bad.Check(&why));
  EXPECT_NE(why.find("must be a .yaml file"), std::string::npos) << why;
  bad = o;
  bad.min_height = 1.0;
  bad.max_height = 0.5;
  EXPECT_FALSE(bad.Check(&why));
  EXPECT_NE(why.find("--min-height"), std::string::npos) << why;
  bad = o;
  bad.pixels_per_cell = 33;
  EXPECT_FALSE(bad.Check(&why));
  bad = o;
  bad.image = "pic.jpg";
  EXPECT_FALSE(bad.Check(&why));
  bad = o;
  bad.integration.resolution = 0;
  EXPECT_FALSE(bad.Check(&why));
  EXPECT_NE(why.find("--resolution"), std::string::npos) << why;
  bad = o;
  bad.out = "seq/map.yaml";
  EXPECT_FALSE(bad.Check(&why));
}

}  // namespace
}  // namespace rrslam
