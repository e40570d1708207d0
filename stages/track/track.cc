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
#include "common/json_text.h"
#include "common/output_path.h"
#include "common/progress.h"
#include "common/settings.h"
#include "common/task_thread.h"
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
// Tracking cached features needs no gray image: `camera_size` given, only
// the depth is loaded (restore mapping's change evidence) and checked to be
// of that size.
class ImagePrefetcher {
 public:
  struct Images {
    cv::Mat gray;
    cv::Mat depth_metres;
    double load_ms = 0;
  };

  ImagePrefetcher(const RgbdSequence& sequence, std::vector<size_t> frames, double depth_map_factor,
                  std::optional<cv::Size> camera_size = std::nullopt, size_t capacity = 4)
      : sequence_(sequence),
        frames_(std::move(frames)),
        depth_map_factor_(depth_map_factor),
        camera_size_(camera_size),
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
        const cv::Mat depth_raw = sequence_.LoadDepthRaw(i);
        if (camera_size_) {
          CheckCameraSize(depth_raw, sequence_.frame(i).depth_path);
        } else {
          slot.images.gray = sequence_.LoadGray(i);
          CheckSameSize(slot.images.gray, depth_raw, sequence_.frame(i).depth_path);
        }
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

  void CheckCameraSize(const cv::Mat& depth, const std::filesystem::path& path) const {
    if (depth.size() != *camera_size_) {
      throw DataError(path.string() + ": depth is " + std::to_string(depth.cols) + "x" +
                      std::to_string(depth.rows) + " but the features' camera is " +
                      std::to_string(camera_size_->width) + "x" +
                      std::to_string(camera_size_->height));
    }
  }

  const RgbdSequence& sequence_;
  const std::vector<size_t> frames_;
  const double depth_map_factor_;
  const std::optional<cv::Size> camera_size_;
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

// A features file's frames must come from this sequence's images, not from
// files of the same names elsewhere (another synthetic sequence's frames are
// all named rgb/000000.png, ... with the same timestamps): the rgb and depth
// checksums recorded by extract (format 1.1) of kCheckedFeatureFrames frames
// spread over the tracked ones, the first and last included, must be those
// of the sequence's files. A format 1.0 file records none and is not checked.
// `frames[k]` is the sequence frame of features-file frame `first + k`.
constexpr size_t kCheckedFeatureFrames = 16;

void CheckFeatureImages(const std::string& name, const FeaturesFile& features,
                        const RgbdSequence& sequence, const std::vector<size_t>& frames,
                        size_t first) {
  if (features.format.minor < 1) {
    spdlog::warn(
        "{}: format 1.0 records no image checksums; its frames are not checked "
        "against the images of {}",
        name, sequence.dir().string());
    return;
  }
  const size_t n = std::min(kCheckedFeatureFrames, frames.size());
  for (size_t j = 0; j < n; ++j) {
    const size_t k = n == 1 ? 0 : j * (frames.size() - 1) / (n - 1);
    const FrameRecord& r = features.frames.at(first + k);
    const RgbdFrameRef& frame = sequence.frame(frames[k]);
    const std::pair<const std::filesystem::path*, uint64_t> files[] = {
        {&frame.rgb_path, r.rgb_checksum}, {&frame.depth_path, r.depth_checksum}};
    for (const auto& [path, recorded] : files) {
      if (FileChecksum64(*path) != recorded) {
        throw DataError(name + ": frame " + std::to_string(first + k) +
                        " was extracted from other image bytes than " + path->string() +
                        " (checksums differ); extract the features of this sequence again");
      }
    }
  }
}

// What the run knows of the map it loaded (none: every field zero/empty).
struct LoadedMap {
  std::string identity;
  uint64_t next_keyframe_id = 0;
  uint64_t next_map_point_id = 0;
  size_t keyframes = 0;
  size_t map_points = 0;
  size_t other_maps = 0;  // Kept beside it in the file (since map format 1.1).
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
  std::string module_why;
  if (!tracker.Check(&module_why) || !local_mapping.Check(&module_why) ||
      !atlas.Check(&module_why) || !revisit_culling.Check(&module_why)) {
    return fail(module_why);
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
          {"close_tracked", tracker.close_tracked},
          {"restore_close_tracked", restore_close_tracked},
          {"new_view_fraction", tracker.new_view_fraction},
          {"new_view_min_age", tracker.new_view_min_age},
          {"ba_depth_fallback", local_mapping.bundle_adjustment.depth_fallback},
          {"small_vocab_groups", small_vocab_groups},
          {"expand_all_local_keyframes", tracker.expand_all_local_keyframes},
          {"last_frame_fallback", tracker.last_frame_fallback},
          {"relocalization", ToString(tracker.relocalization.method)},
          {"relocalization_covisible", tracker.relocalization.bow_covisible},
          {"loop_closing", loop_closing},
          {"refine_map", refine_map},
          {"cull_revisits", revisit_culling.enabled},
          {"revisit_distance", revisit_culling.max_distance},
          {"revisit_angle", revisit_culling.max_angle_deg},
          {"save_map", save_map.string()},
          {"load_map", load_map.string()},
          {"first_frame", first_frame},
          {"localization_only", localization_only},
          {"changed_point_views", local_mapping.changed_point_min_views},
          {"changed_point_ratio", local_mapping.changed_point_min_found_ratio},
          {"changed_point_absent", local_mapping.changed_point_min_absent},
          {"restore_point_found", local_mapping.restore_point_min_found},
          {"new_map_after_s", atlas.new_map_after_s}};
}

namespace {

// One run of the stage, its steps in the pipeline's order: open the inputs
// and outputs, build the SLAM modules, load a saved map, track the frames,
// check that tracking started, refine, write the trajectories and the map,
// write the report, commit. The objects a step makes are members, declared
// so that the modules (whose threads use the map) go before the map.
class TrackSession {
 public:
  explicit TrackSession(const TrackOptions& options) : options_(options) {}

  TrackSummary Run() {
    OpenInputs();
    OpenOutputs();
    BuildModules();
    if (!options_.load_map.empty()) LoadMap();
    // On a thread, and so a heap, of its own (common/task_thread.h): a loaded
    // map leaves the main heap its live objects interleaved with the freed
    // records, and each frame's many small blocks (a pose optimization's
    // residuals) searched and merged those holes: tracking on the 10k-keyframe
    // map spent 11% of its time in malloc's internals against 4% on the
    // 93-keyframe map (3% on a heap of its own; docs/mapstore.md).
    TaskThread frame_loop;
    frame_loop.Run([this] { TrackFrames(); });
    CheckTrackingStarted();
    if (mapping_) CullRevisits();
    if (options_.refine_map && mapping_) Refine();
    Summarize();
    WriteTrajectories();
    if (map_output_) WriteMap();
    Write("run.json", DumpJson(Report(), 2) + "\n");
    Commit();
    LogSummary();
    return summary_;
  }

 private:
  // Settings, sequence, the frames to track (of a features file, or all),
  // vocabulary and sensor model.
  void OpenInputs() {
    std::string why;
    if (!options_.Check(&why)) throw UsageError(why);
    settings_ = ReadSettings(options_.settings);
    SequenceOptions sequence_options;
    sequence_options.associations = options_.associations;
    // An image larger than the calibration's is refused from its header.
    sequence_options.max_image_size = {
        settings_.width, settings_.height,
        "Camera.width x Camera.height of " + options_.settings.string()};
    sequence_ = RgbdSequence::Open(options_.sequence, sequence_options);
    use_features_ = !options_.features.empty();
    if (use_features_) {
      OpenFeatures();
    } else {
      for (size_t i = 0; i < sequence_.size(); ++i) frames_.push_back(i);
    }
    SelectFrames();
    if (use_features_) {
      CheckFeatureImages(options_.features.string(), features_, sequence_, frames_, first_kept_);
    }
    const auto vocabulary_start = SteadyClock::now();
    vocabulary_ = Vocabulary::Load(options_.vocabulary);
    if (vocabulary_.empty()) {
      throw DataError(options_.vocabulary.string() + ": vocabulary has no words");
    }
    summary_.startup.vocabulary_load_ms = MillisecondsSince(vocabulary_start);
    // The image size comes from the settings or from the first image.
    width_ = settings_.width;
    height_ = settings_.height;
    if (width_ <= 0 || height_ <= 0) {
      const cv::Mat first = LoadGrayImage(sequence_.frame(frames_.front()).rgb_path);
      width_ = first.cols;
      height_ = first.rows;
    }
    sensor_.emplace(settings_, width_, height_);
  }

  void OpenFeatures() {
    features_ = ReadFeaturesFile(options_.features);
    const std::string name = options_.features.string();
    if (features_.settings_yaml.empty()) {
      throw DataError(name + ": records no settings; cannot check it against " +
                      options_.settings.string());
    }
    CheckFeaturesSettings(name, ParseSettings(features_.settings_yaml, name + " (settings)"),
                          settings_);
    frames_ = MatchFeatureFrames(name, features_, sequence_);
  }

  // --first-frame and --max-frames; at least 2 frames remain.
  void SelectFrames() {
    if (options_.first_frame > 0) {
      const size_t first = static_cast<size_t>(options_.first_frame);
      const auto kept = std::lower_bound(frames_.begin(), frames_.end(), first);
      first_kept_ = static_cast<size_t>(kept - frames_.begin());
      frames_.erase(frames_.begin(), kept);
    }
    if (options_.max_frames > 0 && frames_.size() > static_cast<size_t>(options_.max_frames)) {
      frames_.resize(options_.max_frames);
    }
    if (frames_.size() < 2) {
      throw DataError((use_features_ ? options_.features : options_.sequence).string() + ": " +
                      std::to_string(frames_.size()) +
                      " frame(s) to track; tracking needs at least 2");
    }
  }

  // Reserved before tracking, so that an output that cannot be written
  // fails first. An existing --out is replaced only when it is empty or an
  // earlier rrslam-track output (common/atomic_file.h).
  void OpenOutputs() {
    output_.emplace(
        options_.out, AtomicOutput::Kind::kDirectory,
        OutputFolderOwner{.tool = "rrslam-track",
                          .files = {"CameraTrajectory.txt", "KeyFrameTrajectory.txt", "run.json"},
                          .folders = {},
                          .record = "run.json"});
    if (!options_.save_map.empty()) map_output_.emplace(options_.save_map);
    spdlog::info("track: {} frames of {} ({} mode), vocabulary {}", frames_.size(),
                 options_.sequence.string(), options_.mode, vocabulary_.Identity());
  }

  // The map's keyframe database, the local mapper, the tracker and the loop
  // closer, with their options from the run's.
  void BuildModules() {
    database_ = std::make_unique<KeyFrameDatabase>(vocabulary_);
    bow_levels_up_ = FeatureVectorLevelsUp(vocabulary_.levels(), options_.small_vocab_groups);
    // The options the user gave, and those that follow from the inputs.
    tracker_options_ = options_.tracker;
    tracker_options_.max_keyframe_gap = std::max(1, static_cast<int>(std::lround(settings_.fps)));
    if (!options_.load_map.empty()) tracker_options_.close_tracked = options_.restore_close_tracked;
    tracker_options_.bow_levels_up = bow_levels_up_;
    LocalMapperOptions mapper_options = options_.local_mapping;
    mapper_options.bow_levels_up = bow_levels_up_;
    tracker_options_.localization_only = options_.localization_only;
    tracker_options_.restore_mapping = !options_.load_map.empty() && !options_.localization_only;
    mapper_ = std::make_unique<LocalMapper>(*sensor_, vocabulary_, &map_, database_.get(),
                                            mapper_options);
    tracker_ = std::make_unique<Tracker>(*sensor_, vocabulary_, &map_, mapper_.get(), *database_,
                                         tracker_options_);
    closer_ =
        std::make_unique<LoopCloser>(*sensor_, vocabulary_, &map_, database_.get(), mapper_.get());
    if (!options_.load_map.empty() && mapping_ && options_.atlas.new_map_after_s >= 0) {
      atlas_ = std::make_unique<Atlas>(*sensor_, vocabulary_, options_.atlas);
    }
    mapper_->SetKeyFrameSink([this](KeyFrame* kf) {
      if (options_.loop_closing) closer_->Enqueue(kf);
      if (atlas_) atlas_->Enqueue(kf);  // Checked only while the loaded map is aside.
    });
    camera_ = MapCameraFrom(settings_, width_, height_);
  }

  // A saved map: loaded, checked against this camera and vocabulary, and
  // its keyframe database rebuilt; tracking starts lost in it.
  void LoadMap() {
    const auto map_start = SteadyClock::now();
    const std::string source = options_.load_map.string();
    // The load's allocations (the file's records, then the live map) on this
    // thread, in prepared huge-page memory; the keyframes' keypoints and
    // descriptors stay in the file's mapping.
    const HeapReservation heap = ReserveHeapForLoadMap(options_.load_map);
    MapFileInfo info;
    MapData data = ReadMapFile(options_.load_map, &info);
    CheckMapCompatible(data, camera_, vocabulary_, source);
    TrackStartup& startup = summary_.startup;
    startup.map_read_ms = MillisecondsSince(map_start);
    loaded_.next_keyframe_id = data.next_keyframe_id;
    loaded_.next_map_point_id = data.next_map_point_id;
    loaded_.keyframes = data.keyframes.size();
    loaded_.map_points = data.map_points.size();
    // Maps kept beside it (since map format 1.1) are not tracked in; saved again.
    carried_maps_ = std::move(data.other_maps);
    loaded_.other_maps = carried_maps_.size();
    LoadMapData(std::move(data), *sensor_, vocabulary_, bow_levels_up_, &map_, database_.get(),
                source);
    startup.map_load_ms = MillisecondsSince(map_start);
    loaded_.identity = MapIdentity(info);
    tracker_->StartOnLoadedMap();
    if (!options_.localization_only) mapper_->WatchLoadedPoints(map_.MapPoints());
    if (!carried_maps_.empty()) {
      spdlog::info("track: {} keeps {} other map(s) beside it: not tracked in, saved again", source,
                   carried_maps_.size());
    }
    spdlog::info("track: map {} loaded in {:.1f} ms: {} keyframes, {} map points ({})", source,
                 startup.map_load_ms, loaded_.keyframes, loaded_.map_points,
                 options_.localization_only ? "localization only" : "restore mapping");
  }

  // The frame loop: each frame's features (extracted, or from the features
  // file), tracked; in batch mode local mapping and loop closing run in step
  // after each keyframe, in realtime mode in their own threads.
  void TrackFrames() {
    if (realtime_ && mapping_) {
      mapper_->Start();
      if (options_.loop_closing) closer_->Start();
    } else if (!realtime_) {
      batch_mapping_.emplace();
    }
    if (!use_features_) {
      prefetcher_ =
          std::make_unique<ImagePrefetcher>(sequence_, frames_, settings_.depth_map_factor);
      extractor_ = std::make_unique<OrbExtractor>(settings_.orb, options_.extraction_threads);
    } else if (tracker_options_.restore_mapping) {
      const cv::Size camera_size(sensor_->camera.width(), sensor_->camera.height());
      prefetcher_ = std::make_unique<ImagePrefetcher>(sequence_, frames_,
                                                      settings_.depth_map_factor, camera_size);
    }
    tracking_ms_.reserve(frames_.size());
    ProgressBar progress("track", frames_.size(), "frame");
    loop_start_ = SteadyClock::now();
    if (realtime_ && options_.pace) WarnLongPaceGap(sequence_, frames_, options_.max_pace_gap);
    previous_timestamp_ = sequence_.frame(frames_.front()).rgb_timestamp;
    for (size_t k = 0; k < frames_.size(); ++k) {
      TrackFrame(k);
      progress.Advance();
    }
    if (realtime_ && mapping_) {
      mapper_->Stop();
      closer_->Stop();
    }
    mapper_->ProcessQueued();  // Nothing in realtime mode after Stop(); none left in batch.
    closer_->ProcessQueued();
    if (mapping_) {
      // Restore mapping: the change evidence of the frames after the last
      // keyframe is judged too (where the map has the view, few keyframes
      // are made).
      std::lock_guard<std::mutex> lock(map_.mutex());
      mapper_->CullChangedPoints();
    }
    progress.Finish();
    loop_s_ = std::chrono::duration<double>(SteadyClock::now() - loop_start_).count();
  }

  void TrackFrame(size_t k) {
    const size_t index = frames_[k];
    const double timestamp = sequence_.frame(index).rgb_timestamp;
    std::vector<Keypoint> keypoints;
    std::vector<OrbDescriptor> descriptors;
    cv::Mat gray, depth;
    if (use_features_) {
      const auto kps = features_.FrameKeypoints(first_kept_ + k);
      const auto ds = features_.FrameDescriptors(first_kept_ + k);
      keypoints.assign(kps.begin(), kps.end());
      descriptors.assign(ds.begin(), ds.end());
    }
    if (prefetcher_) {
      ImagePrefetcher::Images images = prefetcher_->Next();
      loading_ms_.push_back(images.load_ms);
      gray = std::move(images.gray);
      depth = std::move(images.depth_metres);
    }
    if (realtime_ && options_.pace) Pace(timestamp);
    if (atlas_) ServeAtlas();

    const auto start = SteadyClock::now();
    if (!use_features_) {
      extractor_->Extract(gray, &keypoints, &descriptors);
      FinishKeypoints(sensor_->camera, depth, &keypoints);
      extraction_ms_.push_back(MillisecondsSince(start));
    }
    Frame frame(k, timestamp,
                BuildFrameFeatures(*sensor_, std::move(keypoints), std::move(descriptors)));
    if (tracker_options_.restore_mapping) frame.depth_metres = std::move(depth);
    bool new_keyframe = false;
    const bool tracked = tracker_->Track(std::move(frame), &new_keyframe);
    TrackStartup& startup = summary_.startup;
    if (tracked && startup.first_pose_frame < 0) {
      startup.first_pose_ms = MillisecondsSince(ProcessStartTime());
      startup.first_pose_frame = static_cast<int64_t>(index);
    }
    if (tracker_->reset_requested()) ResetMap(k);
    if (atlas_ && !tracked && startup.first_pose_frame < 0 && !atlas_->holds_loaded_map() &&
        timestamp - sequence_.frame(frames_.front()).rgb_timestamp >=
            options_.atlas.new_map_after_s) {
      StartNewMap(index, timestamp);
    }
    tracking_ms_.push_back(MillisecondsSince(start));
    if (!realtime_ && new_keyframe) {
      // In step, but on a thread (and so a heap) of their own, as in realtime
      // mode (common/task_thread.h).
      batch_mapping_->Run([this] {
        mapper_->ProcessQueued();
        closer_->ProcessQueued();
      });
#ifndef NDEBUG
      RequireMapInvariants(map_, "after the keyframe of frame " + std::to_string(k));
#endif
    }
  }

  // --pace: waits until the frame's time in the sequence has passed since
  // the loop started. A gap longer than --max-pace-gap is not slept through
  // (a pause in the recording, sequences glued together): it counts as that
  // long.
  void Pace(double timestamp) {
    const double gap = timestamp - previous_timestamp_;
    paced_s_ += gap > options_.max_pace_gap ? options_.max_pace_gap : (gap > 0 ? gap : 0);
    previous_timestamp_ = timestamp;
    std::this_thread::sleep_until(loop_start_ + std::chrono::duration_cast<SteadyClock::duration>(
                                                    std::chrono::duration<double>(paced_s_)));
  }

  // ORB-SLAM2's System::Reset: the mapper drops its work, the map and the
  // keyframe database are emptied, and the next frame initializes anew.
  void ResetMap(size_t k) {
    spdlog::warn("track: frame {} lost with {} keyframes in the map; resetting the map", k,
                 map_.num_keyframes());
    mapper_->Reset();
    closer_->Reset();
    std::lock_guard<std::mutex> lock(map_.mutex());
    map_.Clear();
    database_->Clear();
    tracker_->Reset();
  }

  // Atlas: no relocalization in the loaded map within --new-map-after; the
  // loaded map is set aside and the next frame starts a new map.
  void StartNewMap(size_t index, double timestamp) {
    mapper_->Reset();
    closer_->Reset();
    {
      std::lock_guard<std::mutex> lock(map_.mutex());
      atlas_->SetLoadedMapAside(&map_, database_.get());
    }
    tracker_->StartNewMap();
    tracker_->SetMappingRule(options_.tracker.close_tracked, false);
    new_map_frame_ = static_cast<int64_t>(index);
    new_map_timestamp_ = timestamp;
    spdlog::warn("track: no frame relocalized in {} within {} s; a new map starts after frame {}",
                 options_.load_map.string(), options_.atlas.new_map_after_s, index);
  }

  // Atlas: the new map's keyframes looked for in the loaded map (between
  // frames, in the tracking thread); merged where two agree.
  void ServeAtlas() {
    for (KeyFrame* kf : atlas_->TakeQueued()) {
      bool agreed = false;
      {
        std::lock_guard<std::mutex> lock(map_.mutex());
        agreed = atlas_->Check(kf);
      }
      if (agreed && MergeMaps()) return;
    }
  }

  // The new map into the loaded one, with local mapping paused and loop
  // closing's state (of the new map alone) dropped.
  bool MergeMaps() {
    spdlog::info("track: merging the new map into {}", options_.load_map.string());
    closer_->Reset();
    mapper_->Pause();
    const AtlasMerge* merge = nullptr;
    {
      std::lock_guard<std::mutex> lock(map_.mutex());
      merge = atlas_->Merge(&map_, database_.get());
      if (merge != nullptr) {
        tracker_->MoveWorld(merge->overlap.T_a_b);
        tracker_->SetMappingRule(options_.restore_close_tracked, true);
        // In realtime mode a keyframe the tracker made may wait in local
        // mapping's queue, its points observed by a keyframe not yet in the
        // map: the invariants hold again once it is processed.
        if (!realtime_) RequireMapInvariants(map_, "after the merge");
        std::vector<MapPoint*> loaded_points;
        for (MapPoint* p : map_.MapPoints()) {
          if (p->id() < loaded_.next_map_point_id) loaded_points.push_back(p);
        }
        mapper_->WatchLoadedPoints(loaded_points);
      }
    }
    mapper_->Resume();
    if (merge == nullptr) return false;
    spdlog::info(
        "track: new map merged into {} at {:.6f} s: keyframe {} matched {} ({} points), {} "
        "points fused, {:.0f} ms",
        options_.load_map.string(), merge->timestamp, merge->overlap.b_keyframe->id(),
        merge->overlap.a_keyframe->id(), merge->overlap.matches, merge->weld.points_fused,
        merge->ms);
    return true;
  }

  // The map that holds the loaded objects: the atlas's while it keeps the
  // loaded map aside, else the tracked one.
  const Map& LoadedObjectsMap() const {
    return atlas_ && atlas_->holds_loaded_map() ? atlas_->loaded_map() : map_;
  }

  void CheckTrackingStarted() const {
    if (tracker_->state() == Tracker::State::kNotInitialized) {
      throw AlgorithmError(
          options_.sequence.string() +
          (tracker_->resets() > 0
               ? ": tracking was lost soon after initialization and never initialized again (" +
                     std::to_string(tracker_->resets()) + " resets)"
               : ": tracking never initialized: no frame has more than " +
                     std::to_string(tracker_options_.min_initial_keypoints) + " keypoints with " +
                     std::to_string(tracker_options_.min_initial_points) +
                     " of them with depth (is the depth all zero?)"));
    }
    if (!options_.load_map.empty() && summary_.startup.first_pose_frame < 0) {
      throw AlgorithmError(options_.sequence.string() + ": no frame relocalized in map " +
                           options_.load_map.string() + " (" + std::to_string(frames_.size()) +
                           " frames tried; is it a map of this place?)");
    }
  }

  // Revisit culling (module/revisit_culling.h) of this run's keyframes.
  void CullRevisits() {
    std::lock_guard<std::mutex> lock(map_.mutex());
    revisit_culling_ = CullRevisitKeyFrames(*sensor_, loaded_.next_keyframe_id, &map_,
                                            database_.get(), options_.revisit_culling);
    if (revisit_culling_.culled > 0) {
      spdlog::info("track: {} of {} keyframes on revisits culled in {:.0f} ms",
                   revisit_culling_.culled, revisit_culling_.revisits, revisit_culling_.ms);
    }
  }

  void Refine() {
    std::lock_guard<std::mutex> lock(map_.mutex());
    MapRefinementOptions refine_options;
    refine_options.depth_fallback = options_.local_mapping.bundle_adjustment.depth_fallback;
    refinement_ = RefineMap(*sensor_, &map_, refine_options);
    spdlog::info(
        "track: map refined in {:.0f} ms: {} keyframes, {} points, {} outlier "
        "observations erased, {} steps",
        refinement_.ms, refinement_.keyframes, refinement_.points, refinement_.outliers,
        refinement_.solves.successful_steps);
  }

  void Summarize() {
    summary_.frames = frames_.size();
    for (const TrackedFrame& r : tracker_->records()) {
      if (r.tracked) {
        ++summary_.tracked;
      } else {
        summary_.lost_timestamps.push_back(r.timestamp);
      }
    }
    summary_.lost = summary_.frames - summary_.tracked;
    summary_.keyframes = map_.num_keyframes();
    summary_.map_points = map_.num_map_points();
    if (!options_.load_map.empty()) {
      summary_.startup.relocalization_index_ms = tracker_->relocalization_index_ms();
    }
  }

  // A file of the output folder (not yet committed).
  void Write(const std::string& file, const std::string& content) {
    std::ofstream out(output_->temp_path() / file, std::ios::binary);
    out << content;
    out.flush();
    if (!out) throw CantCreateError((options_.out / file).string() + ": cannot write");
  }

  void WriteTrajectories() {
    Write("CameraTrajectory.txt",
          FormatTumTrajectory(ResolveCameraTrajectory(tracker_->records())));
    Write("KeyFrameTrajectory.txt", FormatTumTrajectory(KeyFrameTrajectory(map_)));
  }

  // The map file, complete but not yet committed (Commit does). A map that
  // breaks an invariant is not written: the --save-map file keeps its content.
  void WriteMap() {
    const auto save_start = SteadyClock::now();
    nlohmann::json metadata;
    metadata["producer"] = Producer("track");
    metadata["options"] = options_.ToJson();
    metadata["settings"] = settings_.source.string();
    metadata["frames"] = {{"first", frames_.front()}, {"last", frames_.back()}};
    // What this run started from: keyframes and map points with smaller ids
    // came from that map (render's --color age tells them apart).
    if (!options_.load_map.empty()) {
      metadata["loaded_map"] = {{"file", options_.load_map.string()},
                                {"identity", loaded_.identity},
                                {"next_keyframe_id", loaded_.next_keyframe_id},
                                {"next_map_point_id", loaded_.next_map_point_id}};
    }
    const std::string path = options_.save_map.string();
    // A new map that never met the loaded one is saved beside it, as another
    // map of the file (since map format 1.1), in its own world frame.
    const Map& saved = LoadedObjectsMap();
    if (&saved != &map_) {
      spdlog::warn(
          "track: the new map ({} keyframes) never met {}; {} keeps it beside the loaded map, in "
          "its own frame",
          map_.num_keyframes(), options_.load_map.string(), path);
    }
    RequireMapInvariants(saved, "(" + path + " not saved)");
    MapData data = ToMapData(saved, camera_, vocabulary_, options_.vocabulary.filename().string(),
                             bow_levels_up_, DumpJson(metadata));
    data.other_maps = std::move(carried_maps_);  // Saved once, not copied.
    if (&saved != &map_) {
      RequireMapInvariants(map_, "(" + path + " not saved)");
      metadata.erase("loaded_map");
      data.other_maps.push_back(ToMapData(map_, camera_, vocabulary_,
                                          options_.vocabulary.filename().string(), bow_levels_up_,
                                          DumpJson(metadata)));
    }
    ValidateMapData(data, path + " (before saving)");
    const MapFileInfo info = WriteMapFileAt(map_output_->temp_path(), data, path);
    map_file_bytes_ = info.file_size;
    other_maps_saved_ = data.other_maps.size();
    saved_identity_ = MapIdentity(info);
    map_save_ms_ = MillisecondsSince(save_start);
    spdlog::info("track: map written for {} in {:.1f} ms ({} keyframes, {} map points, {} bytes)",
                 path, map_save_ms_, data.keyframes.size(), data.map_points.size(),
                 map_file_bytes_);
  }

  // run.json: what ran on what, counts, module statistics, timings, map.
  nlohmann::json Report() const {
    nlohmann::json report;
    report["producer"] = Producer("track");
    report["options"] = options_.ToJson();
    report["vocabulary"] = vocabulary_.Identity();
    report["settings"] = settings_.source.string();
    report["counts"] = {{"frames", summary_.frames},
                        {"tracked", summary_.tracked},
                        {"lost", summary_.lost},
                        {"keyframes", summary_.keyframes},
                        {"map_points", summary_.map_points},
                        {"keyframes_created", map_.num_created_keyframes()},
                        {"keyframes_culled", mapper_->counters().culled_keyframes},
                        {"relocalizations", tracker_->relocalizations()},
                        {"last_frame_fallbacks", tracker_->last_frame_fallbacks()},
                        {"loop_closures", closer_->counters().loops.size()},
                        {"resets", tracker_->resets()}};
    report["lost_timestamps"] = summary_.lost_timestamps;
    report["relocalization_attempts"] = RelocalizationReport();
    const LocalMappingCounters& counters = mapper_->counters();
    report["local_mapping"] = {{"keyframes_processed", counters.keyframes},
                               {"triangulated_points", counters.triangulated_points},
                               {"fused_points", counters.fused_points},
                               {"culled_recent_points", counters.culled_points},
                               {"bundle_adjustments", counters.bundle_adjustments},
                               {"aborted_bundle_adjustments", counters.aborted_bundle_adjustments},
                               {"max_queue", counters.max_queue}};
    report["revisit_culling"] = {{"enabled", options_.revisit_culling.enabled && mapping_},
                                 {"revisits", revisit_culling_.revisits},
                                 {"culled", revisit_culling_.culled},
                                 {"ms", revisit_culling_.ms}};
    report["loop_closing"] = LoopClosingReport();
    report["optimization"] = OptimizationReport();
    report["timings"] = TimingsReport();
    report["startup"] = StartupReport();
    report["map"] = MapReport();
    report["atlas"] = AtlasReport();
    report["peak_rss_mb"] = PeakRssMegabytes();
    return report;
  }

  // Every relocalization attempt: the frame's timestamp, the stage that
  // found its pose ("" none), BoW candidates, direct matches, inliers, times.
  nlohmann::json RelocalizationReport() const {
    nlohmann::json attempts = nlohmann::json::array();
    for (const RelocalizationAttempt& a : tracker_->relocalization_attempts()) {
      attempts.push_back({{"timestamp", a.timestamp},
                          {"stage", a.stage},
                          {"bow_candidates", a.bow_candidates},
                          {"bow_query_ms", a.bow_query_ms},
                          {"bow_stage_ms", a.bow_stage_ms},
                          {"direct_queries", a.direct_queries},
                          {"direct_matches", a.direct_matches},
                          {"inliers", a.inliers},
                          {"index_ms", a.index_ms},
                          {"ms", a.ms}});
    }
    return attempts;
  }

  nlohmann::json LoopClosingReport() const {
    const LoopClosingCounters& loops = closer_->counters();
    nlohmann::json loop_list = nlohmann::json::array();
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
    }
    return {{"enabled", options_.loop_closing},
            {"keyframes_checked", loops.keyframes},
            {"detections", loops.detections},
            {"geometric_rejections", loops.geometric_fails},
            {"loops", loop_list}};
  }

  nlohmann::json OptimizationReport() const {
    const auto solves_json = [](const SolveCounts& c) {
      return nlohmann::json{{"solves", c.solves},
                            {"successful_steps", c.successful_steps},
                            {"at_step_limit", c.at_step_limit},
                            {"beyond_iterations", c.beyond_iterations}};
    };
    const LoopClosingCounters& loops = closer_->counters();
    return {{"pose", solves_json(tracker_->pose_solves())},
            {"local_ba", solves_json(mapper_->counters().bundle_adjustment_solves)},
            {"essential_graph", solves_json(loops.essential_graph)},
            {"global_ba", solves_json(loops.global_ba)},
            {"refinement",
             {{"enabled", options_.refine_map && mapping_},
              {"keyframes", refinement_.keyframes},
              {"points", refinement_.points},
              {"observations", refinement_.observations},
              {"outliers_erased", refinement_.outliers},
              {"initial_cost", refinement_.initial_cost},
              {"final_cost", refinement_.final_cost},
              {"ms", refinement_.ms},
              {"solves", solves_json(refinement_.solves)}}}};
  }

  nlohmann::json TimingsReport() const {
    std::vector<double> global_ba_ms;
    for (const LoopClosure& l : closer_->counters().loops) {
      if (l.global_ba_ms > 0) global_ba_ms.push_back(l.global_ba_ms);
    }
    return {{"tracking", ToJson(SummarizeTimings(tracking_ms_))},
            {"extraction", ToJson(SummarizeTimings(extraction_ms_))},
            {"relocalization", ToJson(SummarizeTimings(tracker_->relocalization_ms()))},
            {"local_mapping", ToJson(SummarizeTimings(mapper_->counters().keyframe_ms))},
            {"loop_detection", ToJson(SummarizeTimings(closer_->counters().detection_ms))},
            {"global_ba", ToJson(SummarizeTimings(global_ba_ms))},
            {"image_loading", ToJson(SummarizeTimings(loading_ms_))},
            {"loop_s", loop_s_},
            {"total_s", std::chrono::duration<double>(SteadyClock::now() - run_start_).count()},
            {"frame_rate_hz", frames_.size() / loop_s_}};
  }

  nlohmann::json StartupReport() const {
    const TrackStartup& startup = summary_.startup;
    return {{"process_to_run_ms", startup_process_to_run_ms_},
            {"vocabulary_load_ms", startup.vocabulary_load_ms},
            {"map_load_ms", startup.map_load_ms},
            {"map_read_ms", startup.map_read_ms},
            {"relocalization_index_ms", startup.relocalization_index_ms},
            {"first_pose_ms", startup.first_pose_ms},
            {"first_pose_frame", startup.first_pose_frame}};
  }

  // Loaded objects still in the map, and objects this run added.
  nlohmann::json MapReport() const {
    size_t kept_keyframes = 0, kept_points = 0, added_keyframes = 0, added_points = 0;
    const Map& loaded = LoadedObjectsMap();
    for (const KeyFrame* kf : loaded.KeyFrames()) {
      kept_keyframes += kf->id() < loaded_.next_keyframe_id;
    }
    for (const MapPoint* p : loaded.MapPoints()) kept_points += p->id() < loaded_.next_map_point_id;
    for (const KeyFrame* kf : map_.KeyFrames()) {
      added_keyframes += kf->id() >= loaded_.next_keyframe_id;
    }
    for (const MapPoint* p : map_.MapPoints()) added_points += p->id() >= loaded_.next_map_point_id;
    return {{"loaded", options_.load_map.string()},
            {"loaded_identity", loaded_.identity},
            {"mode", options_.load_map.empty()    ? "new map"
                     : options_.localization_only ? "localization only"
                                                  : "restore mapping"},
            {"keyframes_loaded", loaded_.keyframes},
            {"map_points_loaded", loaded_.map_points},
            {"keyframes_added", added_keyframes},
            {"map_points_added", added_points},
            {"keyframes_culled", loaded_.keyframes - kept_keyframes},
            {"map_points_culled", loaded_.map_points - kept_points},
            {"changed_points_culled", mapper_->counters().culled_changed_points},
            {"visual_odometry_frames", tracker_->visual_odometry_frames()},
            {"frames_lacking_view", tracker_->frames_lacking_view()},
            {"other_maps_loaded", loaded_.other_maps},
            {"other_maps_saved", other_maps_saved_},
            {"saved", options_.save_map.string()},
            {"saved_identity", saved_identity_},
            {"save_ms", map_save_ms_},
            {"file_bytes", map_file_bytes_}};
  }

  // Maps started and merged (run.json "atlas"); poses of T_a_b as
  // [qw, qx, qy, qz, tx, ty, tz] (x_loaded = T_a_b * x_new).
  nlohmann::json AtlasReport() const {
    nlohmann::json merges = nlohmann::json::array();
    if (!atlas_) return {{"enabled", false}, {"maps_started", 0}, {"merges", merges}};
    for (const AtlasMerge& m : atlas_->merges()) {
      const Rigid3d& T = m.overlap.T_a_b;
      merges.push_back({{"timestamp", m.timestamp},
                        {"frame", frames_.at(m.frame_id)},
                        {"first_match_timestamp", m.first_match_timestamp},
                        {"keyframe", m.overlap.b_keyframe->id()},
                        {"matched_keyframe", m.overlap.a_keyframe->id()},
                        {"matches", m.overlap.matches},
                        {"keyframes_checked", m.keyframes_checked},
                        {"keyframes_matched", m.keyframes_matched},
                        {"points_fused", m.weld.points_fused},
                        {"welding_ba_ms", m.weld.bundle_adjustment.ms},
                        {"ms", m.ms},
                        {"T_a_b",
                         {T.rotation.w(), T.rotation.x(), T.rotation.y(), T.rotation.z(),
                          T.translation.x(), T.translation.y(), T.translation.z()}}});
    }
    const bool started = new_map_frame_ >= 0;
    return {{"enabled", true},
            {"new_map_after_s", options_.atlas.new_map_after_s},
            {"maps_started", started ? 1 : 0},
            {"new_map_after_frame", new_map_frame_},
            {"new_map_timestamp", started ? nlohmann::json(new_map_timestamp_) : nlohmann::json()},
            {"keyframes_checked", atlas_->keyframes_checked()},
            {"check", ToJson(SummarizeTimings(atlas_->check_ms()))},
            {"merges", merges},
            {"unmerged", atlas_->holds_loaded_map()}};
  }

  // The map and the folder are committed together, the map first: a failure
  // before leaves both as they were (the --load-map file too, when the map
  // replaces it); only a failure between the two renames leaves the new map
  // beside the old run folder.
  void Commit() {
    if (map_output_) map_output_->Commit();
    output_->Commit();
  }

  void LogSummary() const {
    if (atlas_ && atlas_->holds_loaded_map()) {
      spdlog::warn(
          "track: the new map never met {}: {} and KeyFrameTrajectory.txt are in the new map's "
          "frame (its first keyframe's camera), not the loaded map's",
          options_.load_map.string(), (options_.out / "CameraTrajectory.txt").string());
    }
    if (summary_.lost > 0) {
      spdlog::warn("track: {} of {} frames lost (first at {:.6f} s); they are left out of {}",
                   summary_.lost, summary_.frames, summary_.lost_timestamps.front(),
                   (options_.out / "CameraTrajectory.txt").string());
    }
    const TimingSummary tracking = SummarizeTimings(tracking_ms_);
    spdlog::info(
        "track: {}/{} frames tracked, {} keyframes, {} map points; tracking median {:.2f} ms, "
        "p95 {:.2f} ms; {:.1f} frames/s",
        summary_.tracked, summary_.frames, summary_.keyframes, summary_.map_points, tracking.median,
        tracking.p95, frames_.size() / loop_s_);
  }

  const TrackOptions& options_;
  const SteadyClock::time_point run_start_ = SteadyClock::now();
  const double startup_process_to_run_ms_ = MillisecondsSince(ProcessStartTime());
  const bool realtime_ = options_.mode == "realtime";
  const bool mapping_ = !options_.localization_only;
  // Inputs (OpenInputs).
  Settings settings_;
  RgbdSequence sequence_;
  bool use_features_ = false;
  FeaturesFile features_;
  std::vector<size_t> frames_;  // Sequence index of each frame to track.
  // Frames --first-frame skipped: frames_[k] is features-file frame first_kept_ + k.
  size_t first_kept_ = 0;
  Vocabulary vocabulary_;
  int width_ = 0, height_ = 0;
  std::optional<SensorModel> sensor_;
  // Outputs, reserved at start (OpenOutputs), committed at the end.
  std::optional<AtomicOutput> output_, map_output_;
  // The SLAM objects (BuildModules, LoadMap); the modules after the map.
  Map map_;
  std::unique_ptr<KeyFrameDatabase> database_;
  // With --load-map and mapping, unless --new-map-after < 0; before the
  // modules, whose threads hand it keyframes.
  std::unique_ptr<Atlas> atlas_;
  int bow_levels_up_ = 0;
  TrackerOptions tracker_options_;
  std::unique_ptr<LocalMapper> mapper_;
  std::unique_ptr<Tracker> tracker_;
  std::unique_ptr<LoopCloser> closer_;
  MapCamera camera_;
  LoadedMap loaded_;
  // The loaded file's other maps (since map format 1.1), until WriteMap saves them.
  std::vector<MapData> carried_maps_;
  int64_t new_map_frame_ = -1;  // Sequence index of the last frame lost before a new map.
  double new_map_timestamp_ = 0;
  // The frame loop (TrackFrames).
  std::unique_ptr<ImagePrefetcher> prefetcher_;
  std::unique_ptr<OrbExtractor> extractor_;
  std::optional<TaskThread> batch_mapping_;  // Batch mode: local mapping and loop closing.
  std::vector<double> tracking_ms_, extraction_ms_, loading_ms_;
  SteadyClock::time_point loop_start_;
  double loop_s_ = 0;
  double paced_s_ = 0, previous_timestamp_ = 0;  // --pace: sequence time delivered so far.
  // Results.
  MapRefinementStats refinement_;
  RevisitCullingStats revisit_culling_;
  TrackSummary summary_;
  double map_save_ms_ = 0;
  size_t other_maps_saved_ = 0;
  size_t map_file_bytes_ = 0;
  std::string saved_identity_;
};

}  // namespace

TrackSummary RunTrack(const TrackOptions& options) { return TrackSession(options).Run(); }

}  // namespace rrslam
