#include "bench/scale/global_ba_while_tracking.h"

#include <atomic>
#include <chrono>
#include <mutex>
#include <numeric>
#include <thread>
#include <utility>

#include "common/clock.h"
#include "common/dataset.h"
#include "common/settings.h"
#include "stages/extract/extract.h"
#include "stages/mapstore/map_file.h"
#include "stages/track/data/keyframe_database.h"
#include "stages/track/data/map.h"
#include "stages/track/data/map_io.h"
#include "stages/track/data/sensor_model.h"
#include "stages/track/module/local_mapper.h"
#include "stages/track/module/tracker.h"
#include "stages/track/optimize/loop_optimizer.h"
#include "stages/vocab/vocabulary.h"

namespace rrslam::bench {
namespace {

// The global BA of loop closing's thread (LoopCloser::RunGlobalBundleAdjustment,
// without pausing local mapping: none runs here), timed step by step.
void RunGlobalBa(const SensorModel& sensor, int iterations, Map* map, GlobalBaWhileTracking* r) {
  const auto start = SteadyClock::now();
  GlobalBundleAdjuster adjuster(sensor, iterations);
  {
    std::lock_guard<std::mutex> lock(map->mutex());
    adjuster.Collect(*map);
  }
  r->collect_ms = MillisecondsSince(start);
  const auto solve_start = SteadyClock::now();
  adjuster.Solve();
  r->solve_ms = MillisecondsSince(solve_start);
  const auto apply_start = SteadyClock::now();
  {
    std::lock_guard<std::mutex> lock(map->mutex());
    adjuster.Apply(map);
  }
  r->apply_ms = MillisecondsSince(apply_start);
  r->total_ms = MillisecondsSince(start);
  r->keyframes = adjuster.stats().keyframes;
  r->points = adjuster.stats().points;
  r->observations = adjuster.stats().observations;
  r->iterations = static_cast<int>(adjuster.stats().solves.successful_steps);
}

// Index into `n` frames of the i-th frame of a walk back and forth over them.
size_t BackAndForth(size_t i, size_t n) {
  if (n < 2) return 0;
  const size_t period = 2 * (n - 1);
  const size_t k = i % period;
  return k < n ? k : period - k;
}

}  // namespace

GlobalBaWhileTracking MeasureGlobalBaWhileTracking(const GlobalBaWhileTrackingOptions& o) {
  GlobalBaWhileTracking r;
  const Settings settings = ReadSettings(o.settings);
  const Vocabulary vocabulary = Vocabulary::Load(o.vocab);
  MapData data = ReadMapFile(o.map);
  const int levels_up = data.bow_levels_up;
  const SensorModel sensor(settings, data.camera.width, data.camera.height);
  Map map;
  KeyFrameDatabase database(vocabulary);
  LoadMapData(std::move(data), sensor, vocabulary, levels_up, &map, &database, o.map.string());

  const RgbdSequence sequence = RgbdSequence::Open(o.sequence);
  std::vector<size_t> indices(static_cast<size_t>(o.frames));
  std::iota(indices.begin(), indices.end(), static_cast<size_t>(o.first_frame));
  const FeaturesFile features = ExtractFrames(sequence, settings, indices, 0);

  TrackerOptions tracker_options;
  tracker_options.localization_only = true;
  tracker_options.bow_levels_up = levels_up;
  LocalMapperOptions mapper_options;
  mapper_options.bow_levels_up = levels_up;
  LocalMapper mapper(sensor, vocabulary, &map, &database, mapper_options);
  Tracker tracker(sensor, vocabulary, &map, &mapper, database, tracker_options);
  tracker.StartOnLoadedMap();

  std::atomic<bool> ba_running{false}, ba_done{false};
  std::thread ba;
  const auto start = SteadyClock::now();
  for (size_t i = 0; !ba_done.load() || !ba.joinable(); ++i) {
    // Paced: frame i is due i / fps seconds after the first.
    const auto due = start + std::chrono::duration_cast<SteadyClock::duration>(
                                 std::chrono::duration<double>(i / o.fps));
    std::this_thread::sleep_until(due);
    if (i == static_cast<size_t>(o.baseline_frames)) {
      ba_running = true;
      ba = std::thread([&] {
        RunGlobalBa(sensor, o.iterations, &map, &r);
        ba_done = true;
      });
    }
    const bool during = ba_running.load() && !ba_done.load();
    const size_t j = BackAndForth(i, indices.size());
    const auto keypoints = features.FrameKeypoints(j);
    const auto descriptors = features.FrameDescriptors(j);
    Frame frame(
        i, i / o.fps,
        BuildFrameFeatures(sensor, std::vector<Keypoint>(keypoints.begin(), keypoints.end()),
                           std::vector<OrbDescriptor>(descriptors.begin(), descriptors.end())));
    const auto track_start = SteadyClock::now();
    const bool tracked = tracker.Track(std::move(frame));
    const double ms = MillisecondsSince(track_start);
    // A frame counts as during the BA when the BA ran at its start or end.
    if (during || (ba_running.load() && !ba_done.load())) {
      r.during_ms.push_back(ms);
      r.lost_during += !tracked;
    } else if (!ba_running.load()) {
      r.before_ms.push_back(ms);
      r.lost_before += !tracked;
    }
  }
  ba.join();
  return r;
}

}  // namespace rrslam::bench
