#include "stages/track/module/atlas.h"

#include <cmath>
#include <utility>

#include "common/clock.h"

namespace rrslam {

bool AtlasOptions::Check(std::string* why) const {
  if (!std::isfinite(new_map_after_s)) {
    *why = "new_map_after_s = " + std::to_string(new_map_after_s) + "; must be finite";
    return false;
  }
  return true;
}

Atlas::Atlas(const SensorModel& sensor, const Vocabulary& vocabulary, const AtlasOptions& options)
    : sensor_(sensor), options_(options), loaded_database_(vocabulary) {}

void Atlas::SetLoadedMapAside(Map* active, KeyFrameDatabase* active_database) {
  active->MoveObjectsTo(&loaded_);
  active_database->Clear();
  loaded_database_.AddAll(loaded_.KeyFrames());
  holds_loaded_map_ = true;
}

void Atlas::Enqueue(KeyFrame* keyframe) {
  std::lock_guard<std::mutex> lock(queue_mutex_);
  queue_.push_back(keyframe);
}

std::vector<KeyFrame*> Atlas::TakeQueued() {
  std::lock_guard<std::mutex> lock(queue_mutex_);
  return std::exchange(queue_, {});
}

bool Atlas::Check(KeyFrame* keyframe) {
  if (!holds_loaded_map_ || keyframe->bad()) return false;
  const auto start = SteadyClock::now();
  ++checked_;
  const std::optional<KeyFrameOverlap> overlap =
      MatchKeyFrame(sensor_, loaded_, loaded_database_, keyframe, options_.merge);
  check_ms_.push_back(MillisecondsSince(start));
  if (!overlap) return false;
  for (const KeyFrameOverlap& earlier : matched_) {
    if (earlier.b_keyframe->bad() || !OverlapsAgree(*overlap, earlier, options_.merge)) continue;
    agreed_ = overlap->matches >= earlier.matches ? *overlap : earlier;
    break;
  }
  matched_.push_back(*overlap);
  return agreed_.has_value();
}

const AtlasMerge* Atlas::Merge(Map* active, KeyFrameDatabase* active_database) {
  if (!agreed_) return nullptr;
  const KeyFrameOverlap overlap = *std::exchange(agreed_, std::nullopt);
  if (overlap.b_keyframe->bad() || overlap.a_keyframe->bad()) return nullptr;
  const auto start = SteadyClock::now();
  AtlasMerge merge;
  merge.timestamp = matched_.back().b_keyframe->timestamp();
  merge.frame_id = matched_.back().b_keyframe->frame_id();
  merge.first_match_timestamp = matched_.front().b_keyframe->timestamp();
  merge.overlap = overlap;
  merge.keyframes_checked = checked_;
  merge.keyframes_matched = static_cast<int>(matched_.size());
  merge.weld = MergeLiveMaps(sensor_, overlap, &loaded_, active, active_database, options_.merge);
  merge.ms = MillisecondsSince(start);
  holds_loaded_map_ = false;
  matched_.clear();
  loaded_database_.Clear();
  merges_.push_back(merge);
  return &merges_.back();
}

}  // namespace rrslam
