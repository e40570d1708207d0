#include "bench/scale/tracked_map.h"

#include <numeric>
#include <utility>
#include <vector>

#include "common/dataset.h"
#include "common/heap_reserve.h"
#include "stages/extract/extract.h"
#include "stages/mapstore/map_file.h"
#include "stages/track/data/map_io.h"

namespace rrslam::bench {

TrackedMap::TrackedMap(const TrackedMapPaths& paths, int first_frame, int frames)
    : settings_(ReadSettings(paths.settings)), vocabulary_(Vocabulary::Load(paths.vocab)) {
  {
    const HeapReservation heap = ReserveHeapForLoadMap(paths.map);
    MapData data = ReadMapFile(paths.map);
    bow_levels_up_ = data.bow_levels_up;
    sensor_ = std::make_unique<SensorModel>(settings_, data.camera.width, data.camera.height);
    database_ = std::make_unique<KeyFrameDatabase>(vocabulary_);
    LoadMapData(std::move(data), *sensor_, vocabulary_, bow_levels_up_, &map_, database_.get(),
                paths.map.string());
  }
  const RgbdSequence sequence = RgbdSequence::Open(paths.sequence);
  std::vector<size_t> indices(static_cast<size_t>(frames));
  std::iota(indices.begin(), indices.end(), static_cast<size_t>(first_frame));
  features_ = ExtractFrames(sequence, settings_, indices, 0);
}

Frame TrackedMap::MakeFrame(size_t i, uint64_t id, double timestamp) const {
  const auto keypoints = features_.FrameKeypoints(i);
  const auto descriptors = features_.FrameDescriptors(i);
  return Frame(
      id, timestamp,
      BuildFrameFeatures(*sensor_, std::vector<Keypoint>(keypoints.begin(), keypoints.end()),
                         std::vector<OrbDescriptor>(descriptors.begin(), descriptors.end())));
}

}  // namespace rrslam::bench
