// A map file loaded in process as `rrslam-track --load-map` loads it (the
// same heap preparation, ReserveHeapForLoadMap, which also sets glibc's
// thresholds for the whole process), with the settings, vocabulary and
// extracted frames of a sequence to track in it: what bench-scale's
// in-process measurements (loop_step_while_tracking.h,
// relocalization_sweep.h) start from.
#pragma once

#include <filesystem>
#include <memory>

#include "common/settings.h"
#include "stages/extract/features_file.h"
#include "stages/track/data/frame.h"
#include "stages/track/data/keyframe_database.h"
#include "stages/track/data/map.h"
#include "stages/track/data/sensor_model.h"
#include "stages/vocab/vocabulary.h"

namespace rrslam::bench {

struct TrackedMapPaths {
  std::filesystem::path map, vocab, settings, sequence;
};

class TrackedMap {
 public:
  // Loads the map and extracts frames [first_frame, first_frame + frames)
  // of the sequence. Throws what loading the map, the vocabulary, the
  // settings or the frames throws.
  TrackedMap(const TrackedMapPaths& paths, int first_frame, int frames);

  const SensorModel& sensor() const { return *sensor_; }
  const Vocabulary& vocabulary() const { return vocabulary_; }
  Map& map() { return map_; }
  KeyFrameDatabase& database() { return *database_; }
  int bow_levels_up() const { return bow_levels_up_; }
  int frames() const { return static_cast<int>(features_.frames.size()); }
  // The i-th extracted frame as a new Frame with id `id` at `timestamp`.
  Frame MakeFrame(size_t i, uint64_t id, double timestamp) const;

 private:
  Settings settings_;
  Vocabulary vocabulary_;
  std::unique_ptr<SensorModel> sensor_;
  Map map_;
  std::unique_ptr<KeyFrameDatabase> database_;
  int bow_levels_up_ = 0;
  FeaturesFile features_;
};

}  // namespace rrslam::bench
