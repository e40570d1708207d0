#include "bench/scale/loop_step_while_tracking.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <mutex>
#include <stdexcept>
#include <thread>
#include <utility>

#include "bench/scale/tracked_map.h"
#include "common/clock.h"
#include "stages/track/data/keyframe_database.h"
#include "stages/track/data/map.h"
#include "stages/track/data/sensor_model.h"
#include "stages/track/module/local_mapper.h"
#include "stages/track/module/loop_closer.h"
#include "stages/track/module/tracker.h"
#include "stages/track/optimize/loop_optimizer.h"
#include "stages/vocab/vocabulary.h"

namespace rrslam::bench {
namespace {

// Runs `collect` and `apply` under the map's lock, `solve` without it, and
// times them into `r`.
template <typename Collect, typename Solve, typename Apply>
void RunPhases(Map* map, Collect collect, Solve solve, Apply apply, LoopStepWhileTracking* r) {
  const auto start = SteadyClock::now();
  {
    std::lock_guard<std::mutex> lock(map->mutex());
    collect();
  }
  r->collect_ms = MillisecondsSince(start);
  const auto solve_start = SteadyClock::now();
  solve();
  r->solve_ms = MillisecondsSince(solve_start);
  const auto apply_start = SteadyClock::now();
  {
    std::lock_guard<std::mutex> lock(map->mutex());
    apply();
  }
  r->apply_ms = MillisecondsSince(apply_start);
  r->total_ms = MillisecondsSince(start);
}

// The global BA of loop closing's thread (LoopCloser::RunGlobalBundleAdjustment,
// without pausing local mapping: none runs here).
void RunGlobalBa(const SensorModel& sensor, int iterations, Map* map, LoopStepWhileTracking* r) {
  GlobalBundleAdjuster adjuster(sensor, iterations);
  RunPhases(
      map, [&] { adjuster.Collect(*map); }, [&] { adjuster.Solve(); }, [&] { adjuster.Apply(map); },
      r);
  r->keyframes = adjuster.stats().keyframes;
  r->points = adjuster.stats().points;
  r->observations = adjuster.stats().observations;
  r->iterations = static_cast<int>(adjuster.stats().solves.successful_steps);
}

// The made-up loop's correction of the newest keyframe: moved by
// `metres` along its camera's x axis and turned by `degrees` about its y axis.
Rigid3d CorrectedPose(const KeyFrame& keyframe, double metres, double degrees) {
  const Rigid3d delta(
      Eigen::Quaterniond(Eigen::AngleAxisd(degrees * M_PI / 180.0, Eigen::Vector3d::UnitY())),
      Eigen::Vector3d(metres, 0, 0));
  return (keyframe.T_world_cam() * delta).Inverse();
}

// The made-up loop's keyframe for the newest of `keyframes` (by id): the
// newest at least `span` before it that shares no point with it (loop
// closing never takes a connected keyframe), else the first.
KeyFrame* LoopKeyFrame(const std::vector<KeyFrame*>& keyframes, int span) {
  const std::vector<KeyFrame*>& covisible = keyframes.back()->covisible();
  for (size_t i = keyframes.size() - 1 - span; i > 0; --i) {
    if (std::find(covisible.begin(), covisible.end(), keyframes[i]) == covisible.end()) {
      return keyframes[i];
    }
  }
  return keyframes.front();
}

// Loop closing's essential graph after the made-up loop (see the header),
// with ORB-SLAM2's weight and steps (LoopClosingOptions).
void RunEssentialGraph(const SensorModel& sensor, const LoopStepWhileTrackingOptions& o, Map* map,
                       LoopStepWhileTracking* r) {
  const LoopClosingOptions loop_options;
  EssentialGraphAdjuster adjuster(sensor, loop_options.essential_graph_min_weight,
                                  loop_options.essential_graph_iterations);
  const auto collect = [&] {
    std::vector<KeyFrame*> keyframes = map->KeyFrames();
    std::sort(keyframes.begin(), keyframes.end(), IdLess());
    KeyFrame* keyframe = keyframes.back();
    map->UpdateConnections(keyframe);
    KeyFrame* matched = LoopKeyFrame(keyframes, o.loop_span);
    r->loop_ids = static_cast<int>(keyframe->id() - matched->id());
    LoopCorrection correction = MoveLoopNeighbourhood(
        sensor, map, keyframe, matched, CorrectedPose(*keyframe, o.correction_m, o.correction_deg));
    const size_t k = std::find(correction.moved.begin(), correction.moved.end(), keyframe) -
                     correction.moved.begin();
    correction.loop_connections[k].push_back(matched);
    adjuster.Collect(*map, std::move(correction));
  };
  RunPhases(
      map, collect, [&] { adjuster.Solve(); }, [&] { adjuster.Apply(map); }, r);
  r->vertices = adjuster.vertices();
  r->edges = adjuster.edges();
  r->iterations = static_cast<int>(adjuster.solves().successful_steps);
}

// Index into `n` frames of the i-th frame of a walk back and forth over them.
size_t BackAndForth(size_t i, size_t n) {
  if (n < 2) return 0;
  const size_t period = 2 * (n - 1);
  const size_t k = i % period;
  return k < n ? k : period - k;
}

}  // namespace

LoopStepWhileTracking MeasureLoopStepWhileTracking(const LoopStepWhileTrackingOptions& o) {
  LoopStepWhileTracking r;
  TrackedMap m({o.map, o.vocab, o.settings, o.sequence}, o.first_frame, o.frames);
  const SensorModel& sensor = m.sensor();
  Map& map = m.map();
  if (o.step == LoopStep::kEssentialGraph &&
      map.num_keyframes() <= static_cast<size_t>(std::max(o.loop_span, 0))) {
    throw std::runtime_error(o.map.string() + ": " + std::to_string(map.num_keyframes()) +
                             " keyframes, too few for a loop over " + std::to_string(o.loop_span));
  }

  TrackerOptions tracker_options;
  tracker_options.localization_only = true;
  tracker_options.bow_levels_up = m.bow_levels_up();
  LocalMapperOptions mapper_options;
  mapper_options.bow_levels_up = m.bow_levels_up();
  LocalMapper mapper(sensor, m.vocabulary(), &map, &m.database(), mapper_options);
  Tracker tracker(sensor, m.vocabulary(), &map, &mapper, m.database(), tracker_options);
  tracker.StartOnLoadedMap();

  std::atomic<bool> step_running{false}, step_done{false};
  std::thread step;
  const auto start = SteadyClock::now();
  for (size_t i = 0; !step_done.load() || !step.joinable(); ++i) {
    // Paced: frame i is due i / fps seconds after the first.
    const auto due = start + std::chrono::duration_cast<SteadyClock::duration>(
                                 std::chrono::duration<double>(i / o.fps));
    std::this_thread::sleep_until(due);
    if (i == static_cast<size_t>(o.baseline_frames)) {
      step_running = true;
      step = std::thread([&] {
        if (o.step == LoopStep::kGlobalBa) {
          RunGlobalBa(sensor, o.iterations, &map, &r);
        } else {
          RunEssentialGraph(sensor, o, &map, &r);
        }
        step_done = true;
      });
    }
    const bool during = step_running.load() && !step_done.load();
    Frame frame = m.MakeFrame(BackAndForth(i, static_cast<size_t>(m.frames())), i, i / o.fps);
    const auto track_start = SteadyClock::now();
    const bool tracked = tracker.Track(std::move(frame));
    const double ms = MillisecondsSince(track_start);
    // A frame counts as during the step when the step ran at its start or end.
    if (during || (step_running.load() && !step_done.load())) {
      r.during_ms.push_back(ms);
      r.lost_during += !tracked;
    } else if (!step_running.load()) {
      r.before_ms.push_back(ms);
      r.lost_before += !tracked;
    }
  }
  step.join();
  return r;
}

}  // namespace rrslam::bench
