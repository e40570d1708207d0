#include "stages/track/map_merge_command.h"

#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "common/cli.h"
#include "common/clock.h"
#include "common/errors.h"
#include "common/output_path.h"
#include "common/settings.h"
#include "stages/mapstore/map_file.h"
#include "stages/mapstore/map_join.h"
#include "stages/track/data/map_io.h"
#include "stages/track/module/map_merger.h"
#include "stages/vocab/vocabulary.h"

namespace rrslam {
namespace {

// A saved map loaded as track's live map with its keyframe database.
struct LiveMap {
  explicit LiveMap(const Vocabulary& vocabulary) : database(vocabulary) {}
  Map map;
  KeyFrameDatabase database;
};

void Load(MapData data, const SensorModel& sensor, const Vocabulary& vocabulary,
          const std::string& source, LiveMap* live) {
  const int levels_up = data.bow_levels_up;
  LoadMapData(std::move(data), sensor, vocabulary, levels_up, &live->map, &live->database, source);
}

std::string TransformText(const Rigid3d& T) {
  const Eigen::AngleAxisd aa(T.rotation);
  char text[160];
  std::snprintf(text, sizeof(text),
                "t = (%.4f, %.4f, %.4f) m, rotation %.3f deg about (%.3f, %.3f, %.3f)",
                T.translation.x(), T.translation.y(), T.translation.z(), aa.angle() * 180.0 / M_PI,
                aa.axis().x(), aa.axis().y(), aa.axis().z());
  return text;
}

std::string Metadata(const MapMergeCommandOptions& o, const MapOverlap& overlap) {
  const Rigid3d& T = overlap.T_a_b;
  nlohmann::json m;
  m["producer"] = Producer("mapstore");
  m["merged"] = {{"a", o.a.string()},
                 {"b", o.b.string()},
                 {"settings", o.settings.string()},
                 {"T_a_b",
                  {T.rotation.w(), T.rotation.x(), T.rotation.y(), T.rotation.z(),
                   T.translation.x(), T.translation.y(), T.translation.z()}},
                 {"a_keyframe", overlap.a_keyframe},
                 {"b_keyframe", overlap.b_keyframe},
                 {"matches", overlap.matches}};
  return m.dump();
}

}  // namespace

bool MapMergeCommandOptions::Check(std::string* why) const {
  if (a.empty() || b.empty() || out.empty() || vocabulary.empty() || settings.empty()) {
    *why = "merge needs maps A and B, --out, --vocab and --settings";
    return false;
  }
  return CheckOutputNotInput({"--out", out}, {{"A", a}, {"B", b}}, why);
}

void BindMapMergeCommand(CLI::App& app, MapMergeCommandOptions* o, std::string* chosen) {
  CLI::App* merge = app.add_subcommand(
      "merge",
      "Merges map B into map A's world frame where they overlap (same vocabulary, camera)");
  merge->add_option("a", o->a, "Map A: the merged map keeps its world frame and ids")->required();
  merge->add_option("b", o->b, "Map B: moved into A's frame, its ids after A's")->required();
  merge->add_option("--out", o->out, "Merged map (written atomically; not A or B)")->required();
  merge->add_option("--vocab", o->vocabulary, "Vocabulary both maps were made with")->required();
  merge->add_option("--settings", o->settings, "Camera settings both maps were made with")
      ->required();
  merge->callback([chosen] { *chosen = "merge"; });
}

std::string RunMapMerge(const MapMergeCommandOptions& o) {
  std::string why;
  if (!o.Check(&why)) throw UsageError(why);
  const auto start = SteadyClock::now();
  const Settings settings = ReadSettings(o.settings);
  const Vocabulary vocabulary = Vocabulary::Load(o.vocabulary);
  MapData data_a = ReadMapFile(o.a), data_b = ReadMapFile(o.b);
  const MapCamera camera = MapCameraFrom(settings, data_a.camera.width, data_a.camera.height);
  CheckMapCompatible(data_a, camera, vocabulary, o.a.string());
  CheckMapCompatible(data_b, camera, vocabulary, o.b.string());
  if (data_a.bow_levels_up != data_b.bow_levels_up) {
    throw DataError(o.b.string() + ": its bags of words group " +
                    std::to_string(data_b.bow_levels_up) + " levels up, " + o.a.string() + "'s " +
                    std::to_string(data_a.bow_levels_up));
  }
  const SensorModel sensor(settings, camera.width, camera.height);
  LiveMap a(vocabulary), b(vocabulary);
  Load(data_a, sensor, vocabulary, o.a.string(), &a);
  Load(data_b, sensor, vocabulary, o.b.string(), &b);

  const std::optional<MapOverlap> overlap = FindOverlap(sensor, a.map, a.database, b.map);
  if (!overlap) {
    throw AlgorithmError(o.b.string() + ": no overlap with " + o.a.string() + " found (" +
                         std::to_string(b.map.num_keyframes()) +
                         " keyframes checked; are they maps of one place?)");
  }
  const KeyFrameId first_b_keyframe = data_a.next_keyframe_id;
  const MapPointId first_b_point = data_a.next_map_point_id;
  const std::string metadata = Metadata(o, *overlap);
  MapData joined_data = JoinMaps(std::move(data_a), std::move(data_b), overlap->T_a_b,
                                 overlap->a_keyframe, overlap->b_keyframe, o.out.string());
  std::vector<MapData> other_maps = std::move(joined_data.other_maps);  // Kept as they are.
  LiveMap joined(vocabulary);
  const int levels_up = joined_data.bow_levels_up;
  Load(std::move(joined_data), sensor, vocabulary, o.out.string(), &joined);
  const MapWeldStats weld = WeldJoinedMap(sensor, &joined.map, first_b_keyframe, first_b_point);
  if (!joined.map.CheckInvariants(&why)) {
    throw std::logic_error("the merged map breaks an invariant (" + o.out.string() +
                           " not written): " + why);
  }
  MapData merged = ToMapData(joined.map, camera, vocabulary, o.vocabulary.filename().string(),
                             levels_up, metadata);
  merged.other_maps = std::move(other_maps);
  WriteMapFile(o.out, merged);

  std::ostringstream text;
  text << "transform B -> A: " << TransformText(overlap->T_a_b) << "\n"
       << "keyframes matched: B " << overlap->b_keyframe << " -> A " << overlap->a_keyframe << " ("
       << overlap->matches << " points; " << overlap->matched_keyframes
       << " keyframes of B matched A, " << overlap->agreeing << " agree)\n"
       << "points fused: " << weld.points_fused << "\n"
       << "welding bundle adjustment: " << weld.bundle_adjustment.keyframes << " keyframes, "
       << weld.bundle_adjustment.points << " points, " << weld.bundle_adjustment.outliers
       << " outlier observations erased, " << weld.bundle_adjustment.ms << " ms\n"
       << "merged: " << merged.keyframes.size() << " keyframes, " << merged.map_points.size()
       << " map points -> " << o.out.string() << " (" << MillisecondsSince(start) << " ms)\n";
  std::cout << text.str();
  return text.str();
}

}  // namespace rrslam
