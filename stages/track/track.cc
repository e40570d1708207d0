#include "stages/track/track.h"

#include <spdlog/spdlog.h>
#include <sys/resource.h>

#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdlib>
#include <deque>
#include <exception>
#include <fstream>
#include <map>
#include <mutex>
#include <optional>
#include <thread>

#include "common/atomic_file.h"
#include "common/binary_header.h"
#include "common/cli.h"
#include "common/clock.h"
#include "common/dataset.h"
#include "common/errors.h"
#include "common/heap_reserve.h"
#include "common/json_text.h"
#include "common/output_path.h"
#include "common/progress.h"
#include "common/settings.h"
#include "common/text.h"
#include "common/trajectory.h"
#include "stages/extract/features_file.h"
#include "stages/extract/orb_extractor.h"
#include "stages/mapstore/map_file.h"
#include "stages/track/data/frame.h"
#include "stages/track/data/keyframe_database.h"
#include "stages/track/data/map.h"
#include "stages/track/data/map_io.h"
#include "stages/track/data/sensor_model.h"
#include "stages/track/module/local_mapper.h"
#include "stages/track/module/loop_closer.h"
#include "stages/track/module/tracker.h"
#include "stages/track/optimize/map_refinement.h"
#include "stages/track/optimize/optimizer.h"
#include "stages/track/run_report.h"
#include "stages/vocab/vocabulary.h"

namespace rrslam {
namespace {

// Loads the images of the frames to track on a thread of its own, a few
// frames ahead of the tracker (loading is I/O and decoding, not tracking).
class ImagePrefetcher {
 public:
  struct Images {
    cv::Mat gray;
    cv::Mat depth_metres;
    double load_ms = 0;
  };

  ImagePrefetcher(const RgbdSequence& sequence, std::vector<size_t> frames, double depth_map_factor,
                  size_t capacity = 4)
      : sequence_(sequence),
        frames_(std::move(frames)),
        depth_map_factor_(depth_map_factor),
        capacity_(capacity),
        thread_([this] { Run(); }) {}

  ~ImagePrefetcher() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    cv_.notify_all();
    thread_.join();
  }

  // Images of the next frame, in order. Rethrows the loader's error.
  Images Next() {
    std::unique_lock<std::mutex> lock(mutex_);
    cv_.wait(lock, [this] { return !queue_.empty(); });
    Slot slot = std::move(queue_.front());
    queue_.pop_front();
    lock.unlock();
    cv_.notify_all();
    if (slot.error) std::rethrow_exception(slot.error);
    return std::move(slot.images);
  }

 private:
  struct Slot {
    Images images;
    std::exception_ptr error;
  };

  void Run() {
    for (size_t k = 0; k < frames_.size(); ++k) {
      {
        std::unique_lock<std::mutex> lock(mutex_);
        cv_.wait(lock, [this] { return stop_ || queue_.size() < capacity_; });
        if (stop_) return;
      }
      Slot slot;
      try {
        const auto start = SteadyClock::now();
        const size_t i = frames_[k];
        slot.images.gray = sequence_.LoadGray(i);
        const cv::Mat depth_raw = sequence_.LoadDepthRaw(i);
        CheckSameSize(slot.images.gray, depth_raw, sequence_.frame(i).depth_path);
        depth_raw.convertTo(slot.images.depth_metres, CV_32F, 1.0 / depth_map_factor_);
        slot.images.load_ms = MillisecondsSince(start);
      } catch (...) {
        slot.error = std::current_exception();
      }
      const bool failed = slot.error != nullptr;
      {
        std::lock_guard<std::mutex> lock(mutex_);
        queue_.push_back(std::move(slot));
      }
      cv_.notify_all();
      if (failed) return;
    }
  }

  const RgbdSequence& sequence_;
  const std::vector<size_t> frames_;
  const double depth_map_factor_;
  const size_t capacity_;
  std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<Slot> queue_;
  bool stop_ = false;
  std::thread thread_;
};

// The map's invariants (Map::CheckInvariants); a violation is a bug, so it
// is an internal error (exit 70) naming the invariant and `when`.
void RequireMapInvariants(const Map& map, const std::string& when) {
  std::string why;
  if (!map.CheckInvariants(&why)) {
    throw std::logic_error("the map breaks an invariant " + when + ": " + why);
  }
}

// The settings a features file was extracted with must give the same
// keypoints (camera, depth scale, pyramid) as the tracking settings.
void CheckFeaturesSettings(const std::string& name, const Settings& file, const Settings& s) {
  const SettingPair fields[] = {
      {"Camera.fx", file.fx, s.fx},
      {"Camera.fy", file.fy, s.fy},
      {"Camera.cx", file.cx, s.cx},
      {"Camera.cy", file.cy, s.cy},
      {"Camera.k1", file.distortion.k1, s.distortion.k1},
      {"Camera.k2", file.distortion.k2, s.distortion.k2},
      {"Camera.p1", file.distortion.p1, s.distortion.p1},
      {"Camera.p2", file.distortion.p2, s.distortion.p2},
      {"Camera.k3", file.distortion.k3, s.distortion.k3},
      {"DepthMapFactor", file.depth_map_factor, s.depth_map_factor},
      {"ORBextractor.scaleFactor", file.orb.scale_factor, s.orb.scale_factor},
      {"ORBextractor.nLevels", double(file.orb.n_levels), double(s.orb.n_levels)},
      {"ORBextractor.nFeatures", double(file.orb.n_features), double(s.orb.n_features)},
      {"ORBextractor.iniThFAST", double(file.orb.ini_th_fast), double(s.orb.ini_th_fast)},
      {"ORBextractor.minThFAST", double(file.orb.min_th_fast), double(s.orb.min_th_fast)},
      {"Camera.width", double(file.width), double(s.width)},
      {"Camera.height", double(file.height), double(s.height)},
      {"Camera.RGB", double(file.rgb_order), double(s.rgb_order)},
  };
  if (const SettingPair* d = FirstDifferentSetting(fields)) {
    throw DataError(name + ": extracted with " + d->key + " = " + Format("%.9g", d->recorded) +
                    " but the tracking settings " + s.source.string() + " give " +
                    Format("%.9g", d->given));
  }
}

// Sequence frame of every features-file frame (matched by rgb file name and
// timestamp), in file order.
std::vector<size_t> MatchFeatureFrames(const std::string& name, const FeaturesFile& features,
                                       const RgbdSequence& sequence) {
  std::map<std::string, size_t> by_file;
  for (size_t i = 0; i < sequence.size(); ++i) {
    by_file.emplace(sequence.frame(i).rgb_path.filename().string(), i);
  }
  std::vector<size_t> frames;
  for (size_t f = 0; f < features.num_frames(); ++f) {
    const FrameRecord& r = features.frames[f];
    const std::string file = std::filesystem::path(r.rgb_path).filename().string();
    auto it = by_file.find(file);
    if (it == by_file.end() ||
        std::abs(sequence.frame(it->second).rgb_timestamp - r.rgb_timestamp) > 1e-6) {
      throw DataError(name + ": frame " + std::to_string(f) + " (" + r.rgb_path + " at " +
                      std::to_string(r.rgb_timestamp) + " s) is not a frame of sequence " +
                      sequence.dir().string());
    }
    if (!frames.empty() && it->second <= frames.back()) {
      throw DataError(name + ": frame " + std::to_string(f) + " (" + r.rgb_path +
                      ") is out of order with respect to sequence " + sequence.dir().string());
    }
    frames.push_back(it->second);
  }
  return frames;
}

// What the run knows of the map it loaded (none: every field zero/empty).
struct LoadedMap {
  std::string identity;
  uint64_t next_keyframe_id = 0;
  uint64_t next_map_point_id = 0;
  size_t keyframes = 0;
  size_t map_points = 0;
};

// A map file's identity: XXH3-64 of its sections' checksums (the content,
// not the file's name or time).
std::string MapIdentity(const MapFileInfo& info) {
  std::vector<uint64_t> checksums;
  for (const MapSectionInfo& section : info.sections) checksums.push_back(section.checksum);
  return Hex64(Checksum64(
      {reinterpret_cast<const uint8_t*>(checksums.data()), checksums.size() * sizeof(uint64_t)}));
}

// Says at start when --pace will cut a timestamp gap short, naming the largest.
void WarnLongPaceGap(const RgbdSequence& sequence, const std::vector<size_t>& frames,
                     double max_gap) {
  double largest = 0;
  size_t after = 0;
  for (size_t j = 1; j < frames.size(); ++j) {
    const double gap =
        sequence.frame(frames[j]).rgb_timestamp - sequence.frame(frames[j - 1]).rgb_timestamp;
    if (gap > largest) {
      largest = gap;
      after = j;
    }
  }
  if (largest <= max_gap) return;
  spdlog::warn(
      "track: --pace: the timestamps jump {:.3f} s from frame {} ({:.6f}) to frame {} "
      "({:.6f}); gaps longer than --max-pace-gap = {} s are paced as {} s",
      largest, frames[after - 1], sequence.frame(frames[after - 1]).rgb_timestamp, frames[after],
      sequence.frame(frames[after]).rgb_timestamp, max_gap, max_gap);
}

double PeakRssMegabytes() {
  struct rusage usage {};
  getrusage(RUSAGE_SELF, &usage);
  return usage.ru_maxrss / 1024.0;  // Linux reports kilobytes.
}

}  // namespace

bool TrackOptions::Check(std::string* why) const {
  auto fail = [why](const std::string& message) {
    if (why != nullptr) *why = message;
    return false;
  };
  if (sequence.empty()) return fail("--sequence is empty; an RGB-D sequence folder is required");
  if (settings.empty()) return fail("--settings is empty; a settings YAML file is required");
  if (vocabulary.empty()) return fail("--vocab is empty; a vocabulary file is required");
  if (out.empty()) return fail("--out is empty; an output folder is required");
  // No output may replace, contain or lie inside what the run reads (--out
  // is a folder that is replaced as a whole). --save-map may name the
  // --load-map file: the map is read at start and replaced atomically by the
  // complete new one at the end (updating a robot's map in place).
  std::string clash;
  const std::vector<NamedPath> inputs = {{"--sequence", sequence},
                                         {"--settings", settings},
                                         {"--vocab", vocabulary},
                                         {"--features", features},
                                         {"--associations", associations}};
  std::vector<NamedPath> inputs_and_map = inputs;
  inputs_and_map.push_back({"--load-map", load_map});
  if (!CheckOutputNotInput({"--out", out}, inputs_and_map, &clash) ||
      !CheckOutputNotInput({"--save-map", save_map}, inputs, &clash)) {
    return fail(clash);
  }
  if (!save_map.empty() &&
      !CheckOutputNotInput({"--save-map", save_map}, {{"--out", out}}, &clash)) {
    return fail("--save-map " + save_map.string() + " lies inside --out " + out.string() +
                ", which is replaced as a whole; save the map beside it");
  }
  if (mode != "batch" && mode != "realtime") {
    return fail("--mode = " + mode + "; must be batch or realtime");
  }
  if (max_frames < 0 || max_frames == 1) {
    return fail("--max-frames = " + std::to_string(max_frames) + "; must be 0 (all) or >= 2");
  }
  if (close_tracked < 0) {
    return fail("--close-tracked = " + std::to_string(close_tracked) + "; must be >= 0");
  }
  if (restore_close_tracked < 0) {
    return fail("--restore-close-tracked = " + std::to_string(restore_close_tracked) +
                "; must be >= 0");
  }
  if (!(std::isfinite(max_pace_gap) && max_pace_gap > 0)) {
    return fail("--max-pace-gap = " + fmt::format("{}", max_pace_gap) +
                "; must be a finite number of seconds > 0");
  }
  if (extraction_threads < 1 || extraction_threads > 16) {
    return fail("--extraction-threads = " + std::to_string(extraction_threads) +
                "; must be in [1, 16]");
  }
  if (first_frame < 0) {
    return fail("--first-frame = " + std::to_string(first_frame) + "; must be >= 0");
  }
  if (localization_only && load_map.empty()) {
    return fail("--localization-only needs a map to localize in: give --load-map");
  }
  if (changed_point_views < 0) {
    return fail("--changed-point-views = " + std::to_string(changed_point_views) +
                "; must be >= 0");
  }
  if (changed_point_absent < 0) {
    return fail("--changed-point-absent = " + std::to_string(changed_point_absent) +
                "; must be >= 0");
  }
  if (!(changed_point_ratio >= 0 && changed_point_ratio <= 1)) {
    return fail("--changed-point-ratio = " + std::to_string(changed_point_ratio) +
                "; must be in [0, 1]");
  }
  return true;
}

nlohmann::json TrackOptions::ToJson() const {
  return {{"sequence", sequence.string()},
          {"settings", settings.string()},
          {"vocabulary", vocabulary.string()},
          {"features", features.string()},
          {"associations", associations.string()},
          {"out", out.string()},
          {"mode", mode},
          {"max_frames", max_frames},
          {"pace", pace},
          {"max_pace_gap", max_pace_gap},
          {"extraction_threads", extraction_threads},
          {"close_tracked", close_tracked},
          {"restore_close_tracked", restore_close_tracked},
          {"ba_depth_fallback", ba_depth_fallback},
          {"small_vocab_groups", small_vocab_groups},
          {"expand_all_local_keyframes", expand_all_local_keyframes},
          {"loop_closing", loop_closing},
          {"refine_map", refine_map},
          {"save_map", save_map.string()},
          {"load_map", load_map.string()},
          {"first_frame", first_frame},
          {"localization_only", localization_only},
          {"changed_point_views", changed_point_views},
          {"changed_point_ratio", changed_point_ratio},
          {"changed_point_absent", changed_point_absent}};
}

TrackSummary RunTrack(const TrackOptions& options) {
  const auto run_start = SteadyClock::now();
  const double startup_process_to_run_ms = MillisecondsSince(ProcessStartTime());
  std::string why;
  if (!options.Check(&why)) throw UsageError(why);
  const bool realtime = options.mode == "realtime";

  // Inputs.
  const Settings settings = ReadSettings(options.settings);
  SequenceOptions sequence_options;
  sequence_options.associations = options.associations;
  // An image larger than the calibration's is refused from its header.
  sequence_options.max_image_size = {
      settings.width, settings.height,
      "Camera.width x Camera.height of " + options.settings.string()};
  const RgbdSequence sequence = RgbdSequence::Open(options.sequence, sequence_options);
  std::vector<size_t> frames;
  FeaturesFile features;
  const bool use_features = !options.features.empty();
  if (use_features) {
    features = ReadFeaturesFile(options.features);
    const std::string name = options.features.string();
    if (features.settings_yaml.empty()) {
      throw DataError(name + ": records no settings; cannot check it against " +
                      options.settings.string());
    }
    CheckFeaturesSettings(name, ParseSettings(features.settings_yaml, name + " (settings)"),
                          settings);
    frames = MatchFeatureFrames(name, features, sequence);
  } else {
    for (size_t i = 0; i < sequence.size(); ++i) frames.push_back(i);
  }
  if (options.first_frame > 0) {
    const size_t first = static_cast<size_t>(options.first_frame);
    frames.erase(frames.begin(), std::lower_bound(frames.begin(), frames.end(), first));
  }
  if (options.max_frames > 0 && frames.size() > static_cast<size_t>(options.max_frames)) {
    frames.resize(options.max_frames);
  }
  if (frames.size() < 2) {
    throw DataError((use_features ? options.features : options.sequence).string() + ": " +
                    std::to_string(frames.size()) +
                    " frame(s) to track; tracking needs at least 2");
  }
  TrackSummary summary;
  TrackStartup& startup = summary.startup;
  auto vocabulary_start = SteadyClock::now();
  const Vocabulary vocabulary = Vocabulary::Load(options.vocabulary);
  if (vocabulary.empty())
    throw DataError(options.vocabulary.string() + ": vocabulary has no words");
  startup.vocabulary_load_ms = MillisecondsSince(vocabulary_start);

  // The image size comes from the settings or from the first image.
  int width = settings.width, height = settings.height;
  if (width <= 0 || height <= 0) {
    const cv::Mat first = LoadGrayImage(sequence.frame(frames.front()).rgb_path);
    width = first.cols;
    height = first.rows;
  }
  const SensorModel sensor(settings, width, height);

  // An existing --out is replaced only when it is empty or an earlier
  // rrslam-track output (common/atomic_file.h); checked here, before tracking.
  AtomicOutput output(options.out, AtomicOutput::Kind::kDirectory,
                      {.tool = "rrslam-track",
                       .files = {"CameraTrajectory.txt", "KeyFrameTrajectory.txt", "run.json"},
                       .folders = {},
                       .record = "run.json"});
  // Reserved now, so a --save-map that cannot be written fails before tracking.
  std::optional<AtomicOutput> map_output;
  if (!options.save_map.empty()) map_output.emplace(options.save_map);

  spdlog::info("track: {} frames of {} ({} mode), vocabulary {}", frames.size(),
               options.sequence.string(), options.mode, vocabulary.Identity());

  // The SLAM objects.
  Map map;
  KeyFrameDatabase database(vocabulary);
  const int bow_levels_up = FeatureVectorLevelsUp(vocabulary.levels(), options.small_vocab_groups);
  TrackerOptions tracker_options;
  tracker_options.max_keyframe_gap = std::max(1, static_cast<int>(std::lround(settings.fps)));
  tracker_options.close_tracked =
      options.load_map.empty() ? options.close_tracked : options.restore_close_tracked;
  tracker_options.expand_all_local_keyframes = options.expand_all_local_keyframes;
  tracker_options.bow_levels_up = bow_levels_up;
  LocalMapperOptions mapper_options;
  mapper_options.bow_levels_up = bow_levels_up;
  mapper_options.bundle_adjustment.depth_fallback = options.ba_depth_fallback;
  mapper_options.changed_point_min_views = options.changed_point_views;
  mapper_options.changed_point_min_found_ratio = options.changed_point_ratio;
  mapper_options.changed_point_min_absent = options.changed_point_absent;
  tracker_options.localization_only = options.localization_only;
  tracker_options.restore_mapping = !options.load_map.empty() && !options.localization_only;
  LocalMapper mapper(sensor, vocabulary, &map, &database, mapper_options);
  Tracker tracker(sensor, vocabulary, &map, &mapper, database, tracker_options);
  LoopCloser closer(sensor, vocabulary, &map, &database, &mapper);
  if (options.loop_closing) mapper.SetKeyFrameSink([&closer](KeyFrame* kf) { closer.Enqueue(kf); });

  // A saved map: loaded, checked against this camera and vocabulary, and
  // its keyframe database rebuilt; tracking starts lost in it.
  const MapCamera camera = MapCameraFrom(settings, width, height);
  LoadedMap loaded;
  if (!options.load_map.empty()) {
    const auto map_start = SteadyClock::now();
    const std::string source = options.load_map.string();
    // The load's allocations (the file's records, then the live map: about
    // four times the file's size) on this thread, in huge-page memory.
    std::error_code size_error;
    const uintmax_t file_bytes = std::filesystem::file_size(options.load_map, size_error);
    if (!size_error) ReserveHeap(4 * static_cast<size_t>(file_bytes));
    MapFileInfo info;
    MapData data = ReadMapFile(options.load_map, &info);
    CheckMapCompatible(data, camera, vocabulary, source);
    startup.map_read_ms = MillisecondsSince(map_start);
    loaded.next_keyframe_id = data.next_keyframe_id;
    loaded.next_map_point_id = data.next_map_point_id;
    loaded.keyframes = data.keyframes.size();
    loaded.map_points = data.map_points.size();
    LoadMapData(std::move(data), sensor, vocabulary, bow_levels_up, &map, &database, source);
    startup.map_load_ms = MillisecondsSince(map_start);
    loaded.identity = MapIdentity(info);
    tracker.StartOnLoadedMap();
    if (!options.localization_only) mapper.WatchLoadedPoints(map.MapPoints());
    spdlog::info("track: map {} loaded in {:.1f} ms: {} keyframes, {} map points ({})", source,
                 startup.map_load_ms, loaded.keyframes, loaded.map_points,
                 options.localization_only ? "localization only" : "restore mapping");
  }
  const bool mapping = !options.localization_only;
  if (realtime && mapping) {
    mapper.Start();
    if (options.loop_closing) closer.Start();
  }

  std::unique_ptr<ImagePrefetcher> prefetcher;
  std::unique_ptr<OrbExtractor> extractor;
  if (!use_features) {
    prefetcher = std::make_unique<ImagePrefetcher>(sequence, frames, settings.depth_map_factor);
    extractor = std::make_unique<OrbExtractor>(settings.orb, options.extraction_threads);
  }

  std::vector<double> tracking_ms, extraction_ms, loading_ms;
  tracking_ms.reserve(frames.size());
  ProgressBar progress("track", frames.size(), "frame");
  const auto loop_start = SteadyClock::now();
  if (realtime && options.pace) WarnLongPaceGap(sequence, frames, options.max_pace_gap);
  // --pace: seconds of the sequence delivered so far (gaps capped at
  // --max-pace-gap), and the previous frame's timestamp.
  double paced_s = 0, previous_timestamp = sequence.frame(frames.front()).rgb_timestamp;
  for (size_t k = 0; k < frames.size(); ++k) {
    const size_t index = frames[k];
    const double timestamp = sequence.frame(index).rgb_timestamp;
    std::vector<Keypoint> keypoints;
    std::vector<OrbDescriptor> descriptors;
    cv::Mat gray, depth;
    if (use_features) {
      const auto kps = features.FrameKeypoints(k);
      const auto ds = features.FrameDescriptors(k);
      keypoints.assign(kps.begin(), kps.end());
      descriptors.assign(ds.begin(), ds.end());
    } else {
      ImagePrefetcher::Images images = prefetcher->Next();
      loading_ms.push_back(images.load_ms);
      gray = std::move(images.gray);
      depth = std::move(images.depth_metres);
    }
    if (realtime && options.pace) {
      // A gap longer than --max-pace-gap is not slept through (a pause in
      // the recording, sequences glued together): it counts as that long.
      const double gap = timestamp - previous_timestamp;
      paced_s += gap > options.max_pace_gap ? options.max_pace_gap : (gap > 0 ? gap : 0);
      previous_timestamp = timestamp;
      std::this_thread::sleep_until(loop_start + std::chrono::duration_cast<SteadyClock::duration>(
                                                     std::chrono::duration<double>(paced_s)));
    }

    const auto start = SteadyClock::now();
    if (!use_features) {
      extractor->Extract(gray, &keypoints, &descriptors);
      FinishKeypoints(sensor.camera, depth, &keypoints);
      extraction_ms.push_back(MillisecondsSince(start));
    }
    Frame frame(k, timestamp,
                BuildFrameFeatures(sensor, std::move(keypoints), std::move(descriptors)));
    bool new_keyframe = false;
    const bool tracked = tracker.Track(std::move(frame), &new_keyframe);
    if (tracked && startup.first_pose_frame < 0) {
      startup.first_pose_ms = MillisecondsSince(ProcessStartTime());
      startup.first_pose_frame = static_cast<int64_t>(index);
    }
    if (tracker.reset_requested()) {
      // ORB-SLAM2's System::Reset: the mapper drops its work, the map and the
      // keyframe database are emptied, and the next frame initializes anew.
      spdlog::warn("track: frame {} lost with {} keyframes in the map; resetting the map", k,
                   map.num_keyframes());
      mapper.Reset();
      closer.Reset();
      std::lock_guard<std::mutex> lock(map.mutex());
      map.Clear();
      database.Clear();
      tracker.Reset();
    }
    tracking_ms.push_back(MillisecondsSince(start));
    if (!realtime && new_keyframe) {
      mapper.ProcessQueued();
      closer.ProcessQueued();
#ifndef NDEBUG
      RequireMapInvariants(map, "after the keyframe of frame " + std::to_string(k));
#endif
    }
    progress.Advance();
  }
  if (realtime && mapping) {
    mapper.Stop();
    closer.Stop();
  }
  mapper.ProcessQueued();  // Nothing in realtime mode after Stop(); none left in batch.
  closer.ProcessQueued();
  progress.Finish();
  const double loop_s = std::chrono::duration<double>(SteadyClock::now() - loop_start).count();

  if (tracker.state() == Tracker::State::kNotInitialized) {
    throw AlgorithmError(
        options.sequence.string() +
        (tracker.resets() > 0
             ? ": tracking was lost soon after initialization and never initialized again (" +
                   std::to_string(tracker.resets()) + " resets)"
             : ": tracking never initialized: no frame has more than " +
                   std::to_string(tracker_options.min_initial_keypoints) + " keypoints with " +
                   std::to_string(tracker_options.min_initial_points) +
                   " of them with depth (is the depth all zero?)"));
  }
  if (!options.load_map.empty() && startup.first_pose_frame < 0) {
    throw AlgorithmError(options.sequence.string() + ": no frame relocalized in map " +
                         options.load_map.string() + " (" + std::to_string(frames.size()) +
                         " frames tried; is it a map of this place?)");
  }

  MapRefinementStats refinement;
  if (options.refine_map && mapping) {
    std::lock_guard<std::mutex> lock(map.mutex());
    MapRefinementOptions refine_options;
    refine_options.depth_fallback = options.ba_depth_fallback;
    refinement = RefineMap(sensor, &map, refine_options);
    spdlog::info(
        "track: map refined in {:.0f} ms: {} keyframes, {} points, {} outlier "
        "observations erased, {} steps",
        refinement.ms, refinement.keyframes, refinement.points, refinement.outliers,
        refinement.solves.successful_steps);
  }

  // Outputs.
  summary.frames = frames.size();
  for (const TrackedFrame& r : tracker.records()) {
    if (r.tracked) {
      ++summary.tracked;
    } else {
      summary.lost_timestamps.push_back(r.timestamp);
    }
  }
  summary.lost = summary.frames - summary.tracked;
  summary.keyframes = map.num_keyframes();
  summary.map_points = map.num_map_points();

  const Trajectory camera_trajectory = ResolveCameraTrajectory(tracker.records());
  const Trajectory keyframe_trajectory = KeyFrameTrajectory(map);
  const auto write = [&](const std::string& file, const std::string& content) {
    std::ofstream out(output.temp_path() / file, std::ios::binary);
    out << content;
    out.flush();
    if (!out) throw CantCreateError((options.out / file).string() + ": cannot write");
  };
  write("CameraTrajectory.txt", FormatTumTrajectory(camera_trajectory));
  write("KeyFrameTrajectory.txt", FormatTumTrajectory(keyframe_trajectory));

  // The map file, complete but not yet committed (the folder and the map
  // are committed together at the end).
  double map_save_ms = 0;
  size_t map_file_bytes = 0;
  std::string saved_identity;
  if (map_output) {
    const auto save_start = SteadyClock::now();
    nlohmann::json metadata;
    metadata["producer"] = Producer("track");
    metadata["options"] = options.ToJson();
    metadata["settings"] = settings.source.string();
    metadata["frames"] = {{"first", frames.front()}, {"last", frames.back()}};
    // What this run started from: keyframes and map points with smaller ids
    // came from that map (render's --color age tells them apart).
    if (!options.load_map.empty()) {
      metadata["loaded_map"] = {{"file", options.load_map.string()},
                                {"identity", loaded.identity},
                                {"next_keyframe_id", loaded.next_keyframe_id},
                                {"next_map_point_id", loaded.next_map_point_id}};
    }
    // A broken map is not saved: the --save-map file keeps its content.
    RequireMapInvariants(map, "(" + options.save_map.string() + " not saved)");
    const MapData data = ToMapData(map, camera, vocabulary, options.vocabulary.filename().string(),
                                   bow_levels_up, DumpJson(metadata));
    ValidateMapData(data, options.save_map.string() + " (before saving)");
    const std::vector<uint8_t> bytes = EncodeMap(data);
    {
      std::ofstream out(map_output->temp_path(), std::ios::binary);
      out.write(reinterpret_cast<const char*>(bytes.data()),
                static_cast<std::streamsize>(bytes.size()));
      out.flush();
      if (!out) throw CantCreateError(options.save_map.string() + ": cannot write");
    }
    map_file_bytes = bytes.size();
    saved_identity = MapIdentity(ReadMapFileInfo(bytes, options.save_map.string()));
    map_save_ms = MillisecondsSince(save_start);
    spdlog::info("track: map written for {} in {:.1f} ms ({} keyframes, {} map points, {} bytes)",
                 options.save_map.string(), map_save_ms, data.keyframes.size(),
                 data.map_points.size(), bytes.size());
  }

  const LocalMappingCounters& counters = mapper.counters();
  const TimingSummary tracking = SummarizeTimings(tracking_ms);
  nlohmann::json report;
  report["producer"] = Producer("track");
  report["options"] = options.ToJson();
  report["vocabulary"] = vocabulary.Identity();
  report["settings"] = settings.source.string();
  report["counts"] = {{"frames", summary.frames},
                      {"tracked", summary.tracked},
                      {"lost", summary.lost},
                      {"keyframes", summary.keyframes},
                      {"map_points", summary.map_points},
                      {"keyframes_created", map.num_created_keyframes()},
                      {"keyframes_culled", counters.culled_keyframes},
                      {"relocalizations", tracker.relocalizations()},
                      {"loop_closures", closer.counters().loops.size()},
                      {"resets", tracker.resets()}};
  report["lost_timestamps"] = summary.lost_timestamps;
  report["local_mapping"] = {{"keyframes_processed", counters.keyframes},
                             {"triangulated_points", counters.triangulated_points},
                             {"fused_points", counters.fused_points},
                             {"culled_recent_points", counters.culled_points},
                             {"bundle_adjustments", counters.bundle_adjustments},
                             {"aborted_bundle_adjustments", counters.aborted_bundle_adjustments},
                             {"max_queue", counters.max_queue}};
  auto solves_json = [](const SolveCounts& c) {
    return nlohmann::json{{"solves", c.solves},
                          {"successful_steps", c.successful_steps},
                          {"at_step_limit", c.at_step_limit},
                          {"beyond_iterations", c.beyond_iterations}};
  };
  const LoopClosingCounters& loops = closer.counters();
  nlohmann::json loop_list = nlohmann::json::array();
  std::vector<double> global_ba_ms;
  for (const LoopClosure& l : loops.loops) {
    loop_list.push_back({{"keyframe", l.keyframe},
                         {"matched_keyframe", l.matched},
                         {"timestamp", l.timestamp},
                         {"matched_timestamp", l.matched_timestamp},
                         {"bow_matches", l.bow_matches},
                         {"ransac_inliers", l.ransac_inliers},
                         {"inliers", l.optimized_inliers},
                         {"matches", l.matches},
                         {"correction_m", l.correction_m},
                         {"correction_deg", l.correction_deg},
                         {"correction_ms", l.correction_ms},
                         {"global_ba_ms", l.global_ba_ms},
                         {"global_ba_aborted", l.global_ba_aborted}});
    if (l.global_ba_ms > 0) global_ba_ms.push_back(l.global_ba_ms);
  }
  report["loop_closing"] = {{"enabled", options.loop_closing},
                            {"keyframes_checked", loops.keyframes},
                            {"detections", loops.detections},
                            {"geometric_rejections", loops.geometric_fails},
                            {"loops", loop_list}};
  report["optimization"] = {{"pose", solves_json(tracker.pose_solves())},
                            {"local_ba", solves_json(counters.bundle_adjustment_solves)},
                            {"essential_graph", solves_json(loops.essential_graph)},
                            {"global_ba", solves_json(loops.global_ba)},
                            {"refinement",
                             {{"enabled", options.refine_map && mapping},
                              {"keyframes", refinement.keyframes},
                              {"points", refinement.points},
                              {"observations", refinement.observations},
                              {"outliers_erased", refinement.outliers},
                              {"initial_cost", refinement.initial_cost},
                              {"final_cost", refinement.final_cost},
                              {"ms", refinement.ms},
                              {"solves", solves_json(refinement.solves)}}}};
  report["timings"] = {
      {"tracking", ToJson(tracking)},
      {"extraction", ToJson(SummarizeTimings(extraction_ms))},
      {"relocalization", ToJson(SummarizeTimings(tracker.relocalization_ms()))},
      {"local_mapping", ToJson(SummarizeTimings(counters.keyframe_ms))},
      {"loop_detection", ToJson(SummarizeTimings(loops.detection_ms))},
      {"global_ba", ToJson(SummarizeTimings(global_ba_ms))},
      {"image_loading", ToJson(SummarizeTimings(loading_ms))},
      {"loop_s", loop_s},
      {"total_s", std::chrono::duration<double>(SteadyClock::now() - run_start).count()},
      {"frame_rate_hz", frames.size() / loop_s}};
  report["startup"] = {{"process_to_run_ms", startup_process_to_run_ms},
                       {"vocabulary_load_ms", startup.vocabulary_load_ms},
                       {"map_load_ms", startup.map_load_ms},
                       {"map_read_ms", startup.map_read_ms},
                       {"first_pose_ms", startup.first_pose_ms},
                       {"first_pose_frame", startup.first_pose_frame}};
  {
    // Loaded objects still in the map, and objects this run added.
    size_t kept_keyframes = 0, kept_points = 0, added_keyframes = 0, added_points = 0;
    for (const KeyFrame* kf : map.KeyFrames()) {
      (kf->id() < loaded.next_keyframe_id ? kept_keyframes : added_keyframes) += 1;
    }
    for (const MapPoint* p : map.MapPoints()) {
      (p->id() < loaded.next_map_point_id ? kept_points : added_points) += 1;
    }
    report["map"] = {{"loaded", options.load_map.string()},
                     {"loaded_identity", loaded.identity},
                     {"mode", options.load_map.empty()    ? "new map"
                              : options.localization_only ? "localization only"
                                                          : "restore mapping"},
                     {"keyframes_loaded", loaded.keyframes},
                     {"map_points_loaded", loaded.map_points},
                     {"keyframes_added", added_keyframes},
                     {"map_points_added", added_points},
                     {"keyframes_culled", loaded.keyframes - kept_keyframes},
                     {"map_points_culled", loaded.map_points - kept_points},
                     {"changed_points_culled", counters.culled_changed_points},
                     {"visual_odometry_frames", tracker.visual_odometry_frames()},
                     {"saved", options.save_map.string()},
                     {"saved_identity", saved_identity},
                     {"save_ms", map_save_ms},
                     {"file_bytes", map_file_bytes}};
  }
  report["peak_rss_mb"] = PeakRssMegabytes();
  write("run.json", DumpJson(report, 2) + "\n");
  // The map and the folder are committed together, the map first: a failure
  // before leaves both as they were (the --load-map file too, when the map
  // replaces it); only a failure between the two renames leaves the new map
  // beside the old run folder.
  if (map_output) map_output->Commit();
  output.Commit();

  if (summary.lost > 0) {
    spdlog::warn("track: {} of {} frames lost (first at {:.6f} s); they are left out of {}",
                 summary.lost, summary.frames, summary.lost_timestamps.front(),
                 (options.out / "CameraTrajectory.txt").string());
  }
  spdlog::info(
      "track: {}/{} frames tracked, {} keyframes, {} map points; tracking median {:.2f} ms, "
      "p95 {:.2f} ms; {:.1f} frames/s",
      summary.tracked, summary.frames, summary.keyframes, summary.map_points, tracking.median,
      tracking.p95, frames.size() / loop_s);
  return summary;
}

}  // namespace rrslam
