#include "stages/track/data/map_point_index.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <thread>

#include "stages/track/data/keyframe.h"
#include "stages/track/data/map.h"
#include "stages/track/test_scene.h"

namespace rrslam {
namespace {

using testing::FlipBits;
using testing::RandomDescriptor;

// A map of `n` points with random descriptors.
std::vector<MapPoint*> RandomPoints(Map* map, int n, std::mt19937& rng) {
  std::vector<MapPoint*> points;
  for (int i = 0; i < n; ++i) {
    MapPoint* p = map->CreateMapPoint(Eigen::Vector3d(i, 0, 1), nullptr);
    p->SetDescriptor(RandomDescriptor(rng));
    map->AddMapPoint(p);
    points.push_back(p);
  }
  return points;
}

// The recall goal: a known descriptor among 100k, its copy with 10
// of 256 bits flipped (a good ORB match is within 50) found as the nearest
// at least 95% of the time.
TEST(MapPointIndexTest, FindsAKnownDescriptorAmongAHundredThousand) {
  std::mt19937 rng(3);
  Map map;
  const std::vector<MapPoint*> points = RandomPoints(&map, 100000, rng);
  MapPointIndex index;
  index.Build(map);
  EXPECT_EQ(index.size(), points.size());
  EXPECT_TRUE(index.IsCurrent(map));

  std::vector<OrbDescriptor> queries;
  std::vector<MapPoint*> truth;
  std::uniform_int_distribution<size_t> pick(0, points.size() - 1);
  for (int q = 0; q < 1000; ++q) {
    MapPoint* p = points[pick(rng)];
    queries.push_back(FlipBits(p->descriptor(), 10, rng));
    truth.push_back(p);
  }
  const std::vector<DescriptorNeighbours> found = index.Search(queries);
  ASSERT_EQ(found.size(), queries.size());
  int hits = 0;
  for (size_t q = 0; q < found.size(); ++q) {
    if (found[q].first != truth[q]) continue;
    ++hits;
    EXPECT_EQ(found[q].first_distance, 10);
    // A random descriptor is ~128 bits away.
    if (found[q].second != nullptr) {
      EXPECT_GT(found[q].second_distance, 60);
    }
  }
  EXPECT_GE(hits, 950) << "recall " << hits / 10.0 << "%";
}

// Builds `a` and `b` over 20 000 random points and searches both for
// `queries` descriptors of points (every `stride`th) with 40 of 256 bits
// flipped (far matches, where LSH misses some): expects the same answers
// from both; returns how many found their point.
int SameAnswers(MapPointIndex* a, MapPointIndex* b, int queries, int stride, uint32_t seed) {
  std::mt19937 rng(seed);
  Map map;
  const std::vector<MapPoint*> points = RandomPoints(&map, 20000, rng);
  std::vector<OrbDescriptor> descriptors;
  for (int q = 0; q < queries; ++q) {
    descriptors.push_back(FlipBits(points[q * stride]->descriptor(), 40, rng));
  }
  a->Build(map);
  b->Build(map);
  const std::vector<DescriptorNeighbours> found_a = a->Search(descriptors);
  const std::vector<DescriptorNeighbours> found_b = b->Search(descriptors);
  EXPECT_EQ(found_a.size(), descriptors.size());
  EXPECT_EQ(found_b.size(), descriptors.size());
  int found = 0;
  for (size_t q = 0; q < found_a.size() && q < found_b.size(); ++q) {
    EXPECT_EQ(found_a[q].first, found_b[q].first);
    EXPECT_EQ(found_a[q].second, found_b[q].second);
    EXPECT_EQ(found_a[q].first_distance, found_b[q].first_distance);
    EXPECT_EQ(found_a[q].second_distance, found_b[q].second_distance);
    found += found_a[q].first == points[q * stride];
  }
  return found;
}

// Two builds over the same points answer alike: batch runs repeat exactly.
// (FLANN 1.9's LshIndex draws its key bits from std::random_device.)
TEST(MapPointIndexTest, TheSamePointsGiveTheSameAnswers) {
  MapPointIndex a, b;
  const int found = SameAnswers(&a, &b, 500, 37, 7);
  // Some, not all: the test is on approximate answers.
  EXPECT_GT(found, 250);
  EXPECT_LT(found, 500);
}

// The answers do not depend on the threads a search runs on.
TEST(MapPointIndexTest, AnyNumberOfThreadsGivesTheSameAnswers) {
  MapPointIndexOptions one_thread, three_threads;
  one_thread.threads = 1;
  three_threads.threads = 3;
  MapPointIndex a(one_thread), b(three_threads);
  EXPECT_GT(SameAnswers(&a, &b, 1000, 19, 11), 500);  // Found across every chunk of queries.
}

// Snapshot under the map's lock, tables on another thread (a map just
// loaded): the same index as Build(map).
TEST(MapPointIndexTest, TablesBuiltOnAnotherThreadAnswerAsABuildInPlace) {
  std::mt19937 rng(3);
  Map map;
  const std::vector<MapPoint*> points = RandomPoints(&map, 5000, rng);
  MapPointIndex in_place, in_two_parts;
  in_place.Build(map);
  in_two_parts.Snapshot(map);
  EXPECT_TRUE(in_two_parts.IsCurrent(map));
  std::thread([&] { in_two_parts.BuildTables(); }).join();
  std::vector<OrbDescriptor> queries;
  for (int q = 0; q < 300; ++q) queries.push_back(FlipBits(points[q * 13]->descriptor(), 30, rng));
  const std::vector<DescriptorNeighbours> a = in_place.Search(queries);
  const std::vector<DescriptorNeighbours> b = in_two_parts.Search(queries);
  ASSERT_EQ(a.size(), b.size());
  int found = 0;
  for (size_t q = 0; q < a.size(); ++q) {
    EXPECT_EQ(a[q].first, b[q].first);
    EXPECT_EQ(a[q].second, b[q].second);
    EXPECT_EQ(a[q].first_distance, b[q].first_distance);
    found += b[q].first == points[q * 13];
  }
  EXPECT_GT(found, 150);
}

TEST(MapPointIndexTest, SkipsCulledPointsAndKnowsWhenTheMapChanged) {
  std::mt19937 rng(5);
  Map map;
  const std::vector<MapPoint*> points = RandomPoints(&map, 50, rng);
  MapPointIndex index;
  index.Build(map);
  const std::vector<OrbDescriptor> query = {points[7]->descriptor()};
  EXPECT_EQ(index.Search(query).front().first, points[7]);
  EXPECT_EQ(index.Search(query).front().first_distance, 0);

  map.CullMapPoint(points[7]);
  EXPECT_FALSE(index.IsCurrent(map));
  EXPECT_NE(index.Search(query).front().first, points[7]);
  index.Build(map);
  EXPECT_TRUE(index.IsCurrent(map));
  EXPECT_EQ(index.size(), 49u);

  RandomPoints(&map, 1, rng);
  EXPECT_FALSE(index.IsCurrent(map));
}

TEST(MapPointIndexTest, AnEmptyIndexFindsNothing) {
  Map map;
  MapPointIndex index;
  index.Build(map);
  std::mt19937 rng(1);
  const std::vector<DescriptorNeighbours> found = index.Search({RandomDescriptor(rng)});
  ASSERT_EQ(found.size(), 1u);
  EXPECT_EQ(found.front().first, nullptr);
}

// Points seen by three keyframes each, each keyframe with its own random
// descriptor of a point (three views of one corner, ~128 bits apart), the
// representative the first keyframe's.
struct ThreeViews {
  Map map;
  std::vector<MapPoint*> points;
  std::vector<KeyFrame*> keyframes;
};
void MakeThreeViews(ThreeViews* s, int n, std::mt19937& rng) {
  const SensorModel sensor = testing::TestSensor();
  for (int k = 0; k < 3; ++k) {
    s->keyframes.push_back(testing::MakeGridKeyFrame(&s->map, sensor, n, Rigid3d(), rng));
  }
  for (int i = 0; i < n; ++i) {
    const auto index = static_cast<uint32_t>(i);
    MapPoint* p = testing::MakeObservedPoint(&s->map, s->keyframes, {index, index, index});
    p->SetDescriptor(s->keyframes[0]->features().descriptors[index]);
    s->points.push_back(p);
  }
}

// A query near a point's second view is ~128 bits from its representative:
// beyond a good match (50); the point's observation descriptors find it.
TEST(MapPointIndexTest, ObservationDescriptorsFindAPointFromAnotherView) {
  std::mt19937 rng(5);
  ThreeViews s;
  MakeThreeViews(&s, 500, rng);
  std::vector<OrbDescriptor> queries;
  for (int i = 0; i < 500; ++i) {
    queries.push_back(FlipBits(s.keyframes[1]->features().descriptors[i], 8, rng));
  }
  MapPointIndexOptions representatives;
  representatives.max_rows = 0;
  for (const MapPointIndexOptions& o : {MapPointIndexOptions{}, representatives}) {
    MapPointIndex index(o);
    index.Build(s.map);
    EXPECT_EQ(index.size(), 500u);
    const std::vector<DescriptorNeighbours> found = index.Search(queries);
    int hits = 0;
    for (size_t q = 0; q < found.size(); ++q) {
      if (found[q].first == s.points[q] && found[q].first_distance <= 8) ++hits;
      // Two different points, the first at its nearest descriptor's distance.
      if (found[q].second != nullptr) {
        EXPECT_NE(found[q].first, found[q].second);
      }
      EXPECT_LE(found[q].first_distance, found[q].second_distance);
    }
    if (o.max_rows == 0) {
      EXPECT_EQ(index.rows(), 500u);
      EXPECT_EQ(hits, 0);
    } else {
      EXPECT_EQ(index.rows(), 1500u);
      EXPECT_GE(hits, 475);
    }
  }
}

// A query near two descriptors of one point finds the point once: the
// second nearest is another point or none.
TEST(MapPointIndexTest, APointFoundByTwoOfItsDescriptorsIsNotItsOwnSecond) {
  std::mt19937 rng(7);
  ThreeViews s;
  MakeThreeViews(&s, 200, rng);
  std::vector<OrbDescriptor> queries;
  for (int i = 0; i < 200; ++i) {
    // The representative 12 bits from the first view's descriptor.
    s.points[i]->SetDescriptor(FlipBits(s.keyframes[0]->features().descriptors[i], 12, rng));
    queries.push_back(FlipBits(s.points[i]->descriptor(), 4, rng));
  }
  MapPointIndex index;
  index.Build(s.map);
  const std::vector<DescriptorNeighbours> found = index.Search(queries);
  int hits = 0;
  for (int i = 0; i < 200; ++i) {
    EXPECT_NE(found[i].second, s.points[i]) << i;
    if (found[i].first != s.points[i]) continue;
    ++hits;
    EXPECT_LE(found[i].first_distance, 4) << i;
  }
  EXPECT_GE(hits, 190);
}

// The budget: representatives first, then a round of second descriptors
// (point order) until `max_rows`; a point's view within min_extra_distance
// of those it has adds no row.
TEST(MapPointIndexTest, ObservationDescriptorsStayWithinTheBudget) {
  std::mt19937 rng(6);
  ThreeViews s;
  MakeThreeViews(&s, 100, rng);
  MapPointIndexOptions o;
  o.max_rows = 150;
  MapPointIndex index(o);
  index.Build(s.map);
  EXPECT_EQ(index.rows(), 150u);
  // Points 0-49 have a second descriptor, 50-99 none.
  std::vector<OrbDescriptor> queries;
  for (int i = 0; i < 100; ++i) {
    const KeyFrame& kf = *s.keyframes[1];
    queries.push_back(kf.features().descriptors[i]);
  }
  const std::vector<DescriptorNeighbours> found = index.Search(queries);
  for (int i = 0; i < 100; ++i) {
    // Exactly one of the second and third views was taken (the farther).
    if (i < 50 && found[i].first == s.points[i] && found[i].first_distance == 0) continue;
    if (i < 50) {
      const std::vector<DescriptorNeighbours> third =
          index.Search({s.keyframes[2]->features().descriptors[i]});
      EXPECT_EQ(third[0].first, s.points[i]) << i;
      EXPECT_EQ(third[0].first_distance, 0) << i;
    } else {
      EXPECT_GT(found[i].first_distance, 0) << i;
    }
  }
  o.max_rows = 1000;
  o.min_extra_distance = 256;
  MapPointIndex far_only(o);
  far_only.Build(s.map);
  EXPECT_EQ(far_only.rows(), 100u);
}

// Keys of few bits: fewer possible keys than rows, so every key is present
// and the keys' bitmap is a part of one word (3 of 4 keys of 2 bits probed per
// table, each of 12 tables: a row is missed by all of them with odds of
// 4^-12). The two nearest are then exact, as a scan of every point finds;
// with 9 bits (512 keys, all present) the answers are real points at their
// true distances, the nearest found for most queries.
TEST(MapPointIndexTest, KeysOfFewBitsAreAllPresentAndAnswerAsAScan) {
  std::mt19937 rng(11);
  Map map;
  const std::vector<MapPoint*> points = RandomPoints(&map, 2000, rng);
  std::vector<OrbDescriptor> queries;
  for (int q = 0; q < 200; ++q) queries.push_back(FlipBits(points[q * 7]->descriptor(), 30, rng));
  for (const int bits : {2, 9}) {
    MapPointIndexOptions o;
    o.key_bits = bits;
    MapPointIndex index(o);
    index.Build(map);
    const std::vector<DescriptorNeighbours> found = index.Search(queries);
    int nearest = 0;
    for (size_t q = 0; q < queries.size(); ++q) {
      std::vector<int> d;
      for (const MapPoint* p : points) {
        d.push_back(HammingDistance(ToWords(queries[q]), ToWords(p->descriptor())));
      }
      std::sort(d.begin(), d.end());
      ASSERT_NE(found[q].first, nullptr) << bits << " bits, query " << q;
      ASSERT_NE(found[q].second, nullptr) << bits << " bits, query " << q;
      EXPECT_EQ(found[q].first_distance,
                HammingDistance(ToWords(queries[q]), ToWords(found[q].first->descriptor())));
      EXPECT_EQ(found[q].second_distance,
                HammingDistance(ToWords(queries[q]), ToWords(found[q].second->descriptor())));
      if (bits == 2) {
        EXPECT_EQ(found[q].first_distance, d[0]) << "query " << q;
        EXPECT_EQ(found[q].second_distance, d[1]) << "query " << q;
      }
      nearest += found[q].first_distance == d[0];
    }
    EXPECT_GE(nearest, bits == 2 ? 200 : 150) << bits << " bits";
  }
}

TEST(MapPointIndexTest, OptionsOutOfRangeAreNamed) {
  std::string why;
  EXPECT_TRUE(MapPointIndexOptions{}.Check(&why));
  MapPointIndexOptions o;
  o.key_bits = 40;
  EXPECT_FALSE(o.Check(&why));
  EXPECT_EQ(why, "key_bits = 40; must be in [1, 24]");
  o = {};
  o.threads = 0;
  EXPECT_FALSE(o.Check(&why));
  EXPECT_EQ(why, "threads = 0; must be in [1, 256]");
  o = {};
  o.min_extra_distance = 0;
  EXPECT_FALSE(o.Check(&why));
  EXPECT_EQ(why, "min_extra_distance = 0; must be in [1, 256]");
}

}  // namespace
}  // namespace rrslam
