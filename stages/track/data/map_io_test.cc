#include "stages/track/data/map_io.h"

#include <gtest/gtest.h>

#include <random>

#include "common/errors.h"
#include "common/testing.h"
#include "stages/mapstore/map_compose.h"
#include "stages/mapstore/map_file.h"
#include "stages/track/test_scene.h"

namespace rrslam {
namespace {

using testing::RandomScene;
using testing::ScenePoint;

class MapIoTest : public ::testing::Test {
 protected:
  void SetUp() override {
    // Eight keyframes along x over one scene; every point seen by a keyframe
    // is a map point shared by the keyframes that see it.
    const std::vector<ScenePoint> scene = RandomScene(600, rng_, 2.0, 4.0);
    std::vector<MapPoint*> point_of_scene(scene.size(), nullptr);
    for (int k = 0; k < 8; ++k) {
      const Rigid3d T_cam_world(
          Eigen::Quaterniond(Eigen::AngleAxisd(0.02 * k, Eigen::Vector3d::UnitY())),
          Eigen::Vector3d(-0.1 * k, 0.01 * k, 0));
      const testing::SyntheticView view = testing::RenderView(sensor_, scene, T_cam_world, rng_);
      KeyFrame* kf = map_.CreateKeyFrame(testing::MakeFrame(sensor_, view, 10 * k, T_cam_world));
      map_.AddKeyFrame(kf);
      for (size_t i = 0; i < view.point_of.size(); ++i) {
        MapPoint*& point = point_of_scene[view.point_of[i]];
        if (point == nullptr) {
          point = map_.CreateMapPoint(scene[view.point_of[i]].position, kf);
          map_.AddMapPoint(point);
        }
        map_.AddObservation(point, kf, static_cast<uint32_t>(i));
      }
      map_.UpdateConnections(kf);
      kf->ComputeBow(vocabulary_, 1);
      database_.Add(kf);
      keyframes_.push_back(kf);
    }
    for (MapPoint* point : point_of_scene) {
      if (point == nullptr) continue;
      point->ComputeDistinctiveDescriptor();
      point->UpdateNormalAndDepth(sensor_.pyramid);
      point->IncreaseVisible(3);
      point->IncreaseFound(2);
    }
    // Gaps in the ids (a culled keyframe, a culled point), a loop edge.
    keyframes_.front()->AddLoopEdge(keyframes_.back());
    keyframes_.back()->AddLoopEdge(keyframes_.front());
    ASSERT_TRUE(map_.CullKeyFrame(keyframes_[3]));
    map_.CullMapPoint(point_of_scene[5] != nullptr ? point_of_scene[5] : point_of_scene[6]);
  }

  MapData Save(const Map& map) const {
    return ToMapData(map, MapCameraFrom(settings_, 640, 480), vocabulary_, "hundred.txt", 1,
                     R"({"producer": "test"})");
  }

  const Settings settings_ = testing::TestSettings();
  const SensorModel sensor_ = testing::TestSensor();
  const Vocabulary vocabulary_ = testing::HundredWordVocabulary();
  std::mt19937 rng_{7};
  Map map_;
  KeyFrameDatabase database_{vocabulary_};
  std::vector<KeyFrame*> keyframes_;
};

TEST_F(MapIoTest, SavedMapIsValidAndHasTheMapsObjects) {
  const MapData data = Save(map_);
  ValidateMapData(data, "saved");
  EXPECT_EQ(data.keyframes.size(), map_.num_keyframes());
  EXPECT_EQ(data.map_points.size(), map_.num_map_points());
  EXPECT_EQ(data.next_keyframe_id, 8u);
  for (const KeyFrameRecord& r : data.keyframes) EXPECT_NE(r.id, 3u);  // Culled.
  EXPECT_EQ(data.keyframes.front().parent, kNoId);                     // The root.
  EXPECT_EQ(data.keyframes.front().loop_edges, std::vector<uint64_t>{7});
  EXPECT_EQ(data.keyframes.back().frame_id, 70u);
  EXPECT_EQ(data.vocabulary.content_hash, vocabulary_.content_hash());
}

// Load -> save gives the same records, hence the same bytes; the loaded map
// has every relation of the original.
TEST_F(MapIoTest, LoadThenSaveIsByteIdentical) {
  const MapData saved = Save(map_);
  const std::vector<uint8_t> bytes = EncodeMap(saved);
  const MapData parsed = ParseMap(bytes, "saved.rrm");

  Map loaded;
  KeyFrameDatabase database(vocabulary_);
  LoadMapData(parsed, sensor_, vocabulary_, 1, &loaded, &database, "saved.rrm");
  EXPECT_EQ(EncodeMap(Save(loaded)), bytes);

  EXPECT_EQ(loaded.num_keyframes(), map_.num_keyframes());
  EXPECT_EQ(loaded.num_map_points(), map_.num_map_points());
  EXPECT_EQ(loaded.keyframe_by_id(3), nullptr);
  EXPECT_EQ(loaded.root()->id(), 0u);
  for (const KeyFrame* original : map_.KeyFrames()) {
    const KeyFrame* kf = loaded.keyframe_by_id(original->id());
    ASSERT_NE(kf, nullptr);
    EXPECT_EQ(kf->covisible().size(), original->covisible().size());
    EXPECT_EQ(kf->parent() == nullptr, original->parent() == nullptr);
    if (kf->parent() != nullptr) {
      EXPECT_EQ(kf->parent()->id(), original->parent()->id());
    }
    EXPECT_EQ(kf->children().size(), original->children().size());
    EXPECT_EQ(kf->loop_edges().size(), original->loop_edges().size());
    EXPECT_EQ(kf->NumTrackedMapPoints(1), original->NumTrackedMapPoints(1));
    EXPECT_EQ(kf->bow().entries, original->bow().entries);
    EXPECT_TRUE(kf->T_cam_world().translation.isApprox(original->T_cam_world().translation));
    // The rebuilt inverted index finds it by its words.
    for (const auto& [word, value] : kf->bow().entries) {
      const auto& list = database.KeyFramesWithWord(word);
      EXPECT_NE(std::find(list.begin(), list.end(), kf), list.end());
    }
  }
  const std::vector<MapPoint*> points = loaded.MapPoints();
  ASSERT_EQ(points.size(), map_.num_map_points());
  for (size_t i = 0; i < points.size(); ++i) {
    const MapPoint* original = map_.MapPoints()[i];
    EXPECT_EQ(points[i]->id(), original->id());
    EXPECT_EQ(points[i]->observations().size(), original->observations().size());
    EXPECT_EQ(points[i]->num_observations(), original->num_observations());
    EXPECT_EQ(points[i]->reference_keyframe()->id(), original->reference_keyframe()->id());
    EXPECT_EQ(points[i]->visible(), original->visible());
    EXPECT_EQ(points[i]->found(), original->found());
  }
  // New objects get ids after the saved ones.
  Frame frame(100, 100.0, keyframes_[0]->shared_features());
  EXPECT_EQ(loaded.CreateKeyFrame(frame)->id(), 8u);
  EXPECT_EQ(loaded.CreateMapPoint(Eigen::Vector3d(0, 0, 2), nullptr)->id(),
            map_.num_created_map_points());
}

// A map of many points (their observations are restored on two threads):
// load -> save is still byte-identical.
TEST_F(MapIoTest, ABigMapRoundTripsByteIdentically) {
  ComposeOptions compose;
  compose.copies = 30;
  const MapData big = ComposeMap(Save(map_), compose, [&](KeyFrameRecord* kf) {
    BowVector bow;
    FeatureVector features;
    vocabulary_.Transform(kf->descriptors, &bow, &features, 1);
    kf->bow.assign(bow.entries.begin(), bow.entries.end());
    kf->feature_vector.assign(features.entries.begin(), features.entries.end());
  });
  ASSERT_GT(big.map_points.size(), 10000u);
  const std::vector<uint8_t> bytes = EncodeMap(big);
  Map loaded;
  KeyFrameDatabase database(vocabulary_);
  LoadMapData(ParseMap(bytes, "big.rrm"), sensor_, vocabulary_, 1, &loaded, &database, "big.rrm");
  EXPECT_EQ(EncodeMap(Save(loaded)), bytes);
  EXPECT_EQ(loaded.num_map_points(), big.map_points.size());
}

// Loaded from a file, the keyframes keep their keypoints and descriptors in
// the file's mapping (no copy) and the map stays as read when a new map
// replaces the file (rrslam saves by rename); saved again, it gives the
// file's bytes.
TEST_F(MapIoTest, KeyframesLoadedFromAFileViewItsKeypointsAndDescriptors) {
  const rrslam::testing::TempDir dir;
  const std::vector<uint8_t> bytes = EncodeMap(Save(map_));
  WriteMapFile(dir / "map.rrm", Save(map_));
  Map loaded;
  KeyFrameDatabase database(vocabulary_);
  {
    const HeapReservation heap = ReserveHeapForLoadMap(dir / "map.rrm");
    LoadMapData(ReadMapFile(dir / "map.rrm"), sensor_, vocabulary_, 1, &loaded, &database,
                "map.rrm");
  }
  WriteMapFile(dir / "map.rrm", Save(Map()));
  for (const KeyFrame* kf : loaded.KeyFrames()) {
    EXPECT_TRUE(kf->features().keypoints.is_view());
    EXPECT_TRUE(kf->features().descriptors.is_view());
    const KeyFrame* original = map_.keyframe_by_id(kf->id());
    ASSERT_NE(original, nullptr);
    EXPECT_EQ(kf->features().keypoints, original->features().keypoints);
    EXPECT_EQ(kf->features().descriptors, original->features().descriptors);
    EXPECT_EQ(kf->features().u_right, original->features().u_right);
  }
  EXPECT_EQ(EncodeMap(Save(loaded)), bytes);
  // From bytes in memory they are the frames' own.
  Map parsed;
  KeyFrameDatabase parsed_database(vocabulary_);
  LoadMapData(ParseMap(bytes, "bytes"), sensor_, vocabulary_, 1, &parsed, &parsed_database,
              "bytes");
  EXPECT_FALSE(parsed.KeyFrames().front()->features().keypoints.is_view());
  EXPECT_FALSE(parsed.KeyFrames().front()->features().descriptors.is_view());
}

TEST_F(MapIoTest, FeatureVectorsAreRecomputedForAnotherGrouping) {
  Map loaded;
  KeyFrameDatabase database(vocabulary_);
  LoadMapData(Save(map_), sensor_, vocabulary_, 0, &loaded, &database, "saved.rrm");
  const KeyFrame* kf = loaded.keyframe_by_id(0);
  FeatureVector expected;
  BowVector bow;
  vocabulary_.Transform(kf->features().descriptors, &bow, &expected, 0);
  EXPECT_EQ(kf->feature_vector().entries, expected.entries);
}

TEST_F(MapIoTest, LoadingIntoAMapThatIsNotEmptyIsRefused) {
  KeyFrameDatabase database(vocabulary_);
  EXPECT_THROW(LoadMapData(Save(map_), sensor_, vocabulary_, 1, &map_, &database, "saved.rrm"),
               DataError);
}

// Ids index the live map's arrays: a next id far above the map's size (1e8
// .. 4.6e18, from a forged or corrupt file) is refused before anything is
// allocated for it, naming the field (it made Map::ReserveIds allocate in
// proportion to the id until out of memory).
TEST_F(MapIoTest, NextIdsAboveTheBoundAreRefusedBeforeAllocating) {
  for (uint64_t next : {uint64_t{100000000}, uint64_t{4600000000000000000}}) {
    for (const char* field : {"next_keyframe_id", "next_map_point_id"}) {
      MapData data = Save(map_);
      (field[5] == 'k' ? data.next_keyframe_id : data.next_map_point_id) = next;
      Map loaded;
      KeyFrameDatabase database(vocabulary_);
      try {
        LoadMapData(std::move(data), sensor_, vocabulary_, 1, &loaded, &database, "m.rrm");
        ADD_FAILURE() << field << " " << next << " was loaded";
      } catch (const DataError& e) {
        EXPECT_NE(std::string(e.what()).find(std::string("m.rrm: section meta: ") + field + " " +
                                             std::to_string(next) + " is above"),
                  std::string::npos)
            << e.what();
      }
      EXPECT_EQ(loaded.num_created_keyframes(), 0u);
    }
  }
}

TEST_F(MapIoTest, AnotherCameraOrVocabularyIsRefusedWithTheDifference) {
  const MapData data = Save(map_);
  const MapCamera camera = MapCameraFrom(settings_, 640, 480);
  CheckMapCompatible(data, camera, vocabulary_, "m.rrm");

  MapCamera other = camera;
  other.fx = 517.3;
  try {
    CheckMapCompatible(data, other, vocabulary_, "m.rrm");
    FAIL();
  } catch (const DataError& e) {
    EXPECT_EQ(std::string(e.what()),
              "m.rrm: built with Camera.fx = 500 but the settings give 517.3");
  }
  other = camera;
  other.width = 320;
  EXPECT_THROW(CheckMapCompatible(data, other, vocabulary_, "m.rrm"), DataError);

  MapData renamed = data;
  renamed.vocabulary.name = "elsewhere.rrv";  // The name is not the identity.
  CheckMapCompatible(renamed, camera, vocabulary_, "m.rrm");
  MapData other_tree = data;
  other_tree.vocabulary.content_hash ^= 1;
  try {
    CheckMapCompatible(other_tree, camera, vocabulary_, "m.rrm");
    FAIL();
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.what()).find("m.rrm: built with vocabulary tree"), std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace rrslam
