#include "stages/extract/extract.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <atomic>
#include <exception>
#include <mutex>
#include <thread>

#include "common/atomic_file.h"
#include "common/binary_header.h"
#include "common/cli.h"
#include "common/errors.h"
#include "common/output_path.h"
#include "common/worker_pool.h"
#include "stages/extract/orb_extractor.h"

namespace rrslam {
namespace fs = std::filesystem;

bool ExtractOptions::Check(std::string* why) const {
  auto fail = [&](const std::string& text) {
    if (why != nullptr) *why = text;
    return false;
  };
  if (sequence.empty()) return fail("--sequence is empty; a sequence folder is required");
  if (settings.empty()) return fail("--settings is empty; a settings YAML file is required");
  if (out.empty()) return fail("--out is empty; an output file path is required");
  std::string clash;
  if (!CheckOutputNotInput(
          {"--out", out},
          {{"--sequence", sequence}, {"--settings", settings}, {"--associations", associations}},
          &clash)) {
    return fail(clash);
  }
  if (stride < 1) return fail("--stride = " + std::to_string(stride) + "; must be >= 1");
  if (first < 0) return fail("--first = " + std::to_string(first) + "; must be >= 0");
  if (max_frames < 0) {
    return fail("--max-frames = " + std::to_string(max_frames) + "; must be >= 0 (0 = all)");
  }
  if (threads < 0 || threads > 256) {
    return fail("--threads = " + std::to_string(threads) + "; must be in [0, 256] (0 = all cores)");
  }
  return true;
}

nlohmann::json ExtractOptions::ToJson() const {
  return {{"sequence", sequence.string()},
          {"settings", settings.string()},
          {"associations", associations.string()},
          {"stride", stride},
          {"first", first},
          {"max_frames", max_frames}};
}

nlohmann::json OrbOptionsJson(const OrbSettings& orb) {
  const OrbExtractor extractor(orb);
  return {{"n_features", orb.n_features},
          {"scale_factor", orb.scale_factor},
          {"n_levels", orb.n_levels},
          {"ini_th_fast", orb.ini_th_fast},
          {"min_th_fast", orb.min_th_fast},
          {"features_per_level", extractor.features_per_level()},
          {"edge_threshold", OrbExtractor::kEdgeThreshold},
          {"patch_radius", OrbExtractor::kPatchRadius},
          {"fast_cell_size", OrbExtractor::kFastCellSize},
          {"descriptor_blur", "gaussian 7x7 sigma 2"},
          {"level_to_level0", "x0 = (x + 0.5) * width0 / width_level - 0.5"}};
}

std::vector<size_t> SelectFrames(size_t num_frames, const ExtractOptions& options) {
  std::vector<size_t> frames;
  const size_t stride = static_cast<size_t>(std::max(options.stride, 1));
  for (size_t i = static_cast<size_t>(std::max(options.first, 0)); i < num_frames; i += stride) {
    if (options.max_frames > 0 && frames.size() >= static_cast<size_t>(options.max_frames)) break;
    frames.push_back(i);
  }
  return frames;
}

namespace {

struct FrameFeatures {
  std::vector<Keypoint> keypoints;
  std::vector<OrbDescriptor> descriptors;
  uint64_t rgb_checksum = 0;  // FrameRecord's.
  uint64_t depth_checksum = 0;
};

void ExtractFrame(const RgbdFrameRef& frame, const Settings& settings, const PinholeCamera& camera,
                  OrbExtractor* extractor, FrameFeatures* out) {
  // Refused from the header when larger than the calibration (or than
  // kMaxImageSide when the settings give no size), before it is decoded.
  const ImageSizeLimit limit = {
      settings.width, settings.height,
      "Camera.width x Camera.height of " +
          (settings.source.empty() ? std::string("the settings") : settings.source.string())};
  const cv::Mat gray = LoadGrayImage(frame.rgb_path, limit);
  if ((settings.width > 0 && gray.cols != settings.width) ||
      (settings.height > 0 && gray.rows != settings.height)) {
    throw DataError(
        frame.rgb_path.string() + ": image is " + std::to_string(gray.cols) + "x" +
        std::to_string(gray.rows) + " but " +
        (settings.source.empty() ? std::string("the settings") : settings.source.string()) +
        " gives Camera.width x Camera.height = " + std::to_string(settings.width) + "x" +
        std::to_string(settings.height));
  }
  const cv::Mat depth_raw = LoadDepthImage(frame.depth_path, limit);
  CheckSameSize(gray, depth_raw, frame.depth_path);
  cv::Mat depth_metres;
  depth_raw.convertTo(depth_metres, CV_32F, 1.0 / settings.depth_map_factor);
  extractor->Extract(gray, &out->keypoints, &out->descriptors);
  FinishKeypoints(camera, depth_metres, &out->keypoints);
  // The files were just read, so their bytes are in the page cache.
  out->rgb_checksum = FileChecksum64(frame.rgb_path);
  out->depth_checksum = FileChecksum64(frame.depth_path);
}

}  // namespace

FeaturesFile ExtractFrames(const RgbdSequence& sequence, const Settings& settings,
                           const std::vector<size_t>& frames, int threads, ProgressBar* progress) {
  const PinholeCamera camera = settings.Camera();
  int num_threads = threads > 0 ? threads : static_cast<int>(std::thread::hardware_concurrency());
  num_threads = std::max(num_threads, 1);
  const int frame_workers = static_cast<int>(std::min<size_t>(num_threads, frames.size()));
  // With a single frame the spare threads work on its pyramid levels instead.
  const int threads_per_extractor = frame_workers <= 1 ? num_threads : 1;

  std::vector<FrameFeatures> results(frames.size());
  std::atomic<size_t> next{0};
  std::atomic<bool> failed{false};
  std::mutex error_mutex;
  size_t error_position = frames.size();
  std::exception_ptr error;

  auto worker = [&] {
    OrbExtractor extractor(settings.orb, threads_per_extractor);
    // Frames are claimed in increasing order, so when frame k fails every
    // earlier frame has been claimed and reports its own error, if any: the
    // error kept (the earliest) does not depend on thread timing.
    for (size_t k = next.fetch_add(1); k < frames.size() && !failed.load(); k = next.fetch_add(1)) {
      try {
        ExtractFrame(sequence.frame(frames[k]), settings, camera, &extractor, &results[k]);
      } catch (...) {
        std::lock_guard<std::mutex> lock(error_mutex);
        if (k < error_position) {
          error_position = k;
          error = std::current_exception();
        }
        failed.store(true);
        continue;
      }
      if (progress != nullptr) progress->Advance();
    }
  };
  if (frame_workers <= 1) {
    worker();
  } else {
    // A WorkerPool, so that a thread that cannot be started is a
    // ResourceError (exit 75), not std::terminate.
    WorkerPool pool(frame_workers);
    pool.ParallelFor(static_cast<size_t>(frame_workers), [&](size_t) { worker(); });
  }
  if (error) std::rethrow_exception(error);

  FeaturesFile features;
  size_t total = 0;
  for (const FrameFeatures& r : results) total += r.keypoints.size();
  features.keypoints.reserve(total);
  features.descriptors.reserve(total);
  for (size_t k = 0; k < frames.size(); ++k) {
    const RgbdFrameRef& ref = sequence.frame(frames[k]);
    FrameRecord record;
    record.rgb_timestamp = ref.rgb_timestamp;
    record.depth_timestamp = ref.depth_timestamp;
    record.rgb_path = ref.rgb_path.string();
    record.depth_path = ref.depth_path.string();
    record.rgb_checksum = results[k].rgb_checksum;
    record.depth_checksum = results[k].depth_checksum;
    features.AddFrame(std::move(record), results[k].keypoints, results[k].descriptors);
    results[k] = {};  // Release memory as the file is assembled.
  }
  return features;
}

void RunExtract(const ExtractOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw UsageError(why);
  const Settings settings = ReadSettings(options.settings);
  const std::string settings_text = ReadFileToString(options.settings);
  SequenceOptions sequence_options;
  sequence_options.associations = options.associations;
  const RgbdSequence sequence = RgbdSequence::Open(options.sequence, sequence_options);
  const std::vector<size_t> frames = SelectFrames(sequence.size(), options);
  if (frames.empty()) {
    throw UsageError("--first = " + std::to_string(options.first) + " is past the last frame of " +
                     options.sequence.string() + " (" + std::to_string(sequence.size()) +
                     " paired frames)");
  }
  // Fail now, not after minutes of work, when the output cannot be created
  // (the probe creates nothing and removes a stale temporary).
  { AtomicOutput probe(options.out); }

  spdlog::info("extract: {} of {} frames of {}, {} features per frame", frames.size(),
               sequence.size(), options.sequence.string(), settings.orb.n_features);
  FeaturesFile features;
  {
    ProgressBar progress("extract", frames.size(), "frame");
    features = ExtractFrames(sequence, settings, frames, options.threads, &progress);
  }
  features.settings_yaml = settings_text;
  nlohmann::json recorded = options.ToJson();
  recorded["orb"] = OrbOptionsJson(settings.orb);
  recorded["depth_map_factor"] = settings.depth_map_factor;
  WriteFeaturesFile(options.out, features, Producer("extract"), recorded);
  spdlog::info("extract: wrote {} keypoints ({:.1f} per frame) to {}", features.keypoints.size(),
               static_cast<double>(features.keypoints.size()) / features.num_frames(),
               options.out.string());
}

}  // namespace rrslam
