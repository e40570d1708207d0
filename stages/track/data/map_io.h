// Conversion between track's live map (Map, KeyFrame, MapPoint, the keyframe
// database) and the on-disk map schema of mapstore (MapData).
//
// Saving turns pointers into ids; loading creates every keyframe and map
// point with its saved id, rebuilds every relation (observations on both
// sides, covisibility, spanning tree, loop edges) and the keyframe
// database's inverted index from the saved bags of words. A map loaded and
// saved again without tracking gives the same MapData (and the same bytes).
//
// Thread-safety: the caller holds Map::mutex() or runs no other thread.
#pragma once

#include <filesystem>
#include <string>

#include "common/heap_reserve.h"
#include "common/settings.h"
#include "stages/mapstore/map_data.h"
#include "stages/track/data/keyframe_database.h"
#include "stages/track/data/map.h"
#include "stages/track/data/sensor_model.h"
#include "stages/vocab/vocabulary.h"

namespace rrslam {

// The camera record of a map made with `settings` on images of
// `width` x `height` pixels.
MapCamera MapCameraFrom(const Settings& settings, int width, int height);

// The vocabulary record: its tree identity (Vocabulary::content_hash) and shape.
MapVocabulary MapVocabularyFrom(const Vocabulary& vocabulary, const std::string& name);

// The map's keyframes and map points (those in the map, not culled ones) as
// records; keypoint associations and observations that are not mutual, or
// that involve culled objects, are left out. Bags of words not yet computed
// are computed (with `bow_levels_up`). `metadata` is the JSON recorded as
// MapData::metadata.
MapData ToMapData(const Map& map, const MapCamera& camera, const Vocabulary& vocabulary,
                  const std::string& vocabulary_name, int bow_levels_up,
                  const std::string& metadata);

// Checks that a saved map can be used with this camera and vocabulary.
// Throws DataError naming `source` and the first difference ("built with
// Camera.fx = 525 but the settings give 517.3"; "built with vocabulary tree
// 1a2b... (voc.rrv k=10 L=6 words=...) but --vocab is tree 3c4d...").
void CheckMapCompatible(const MapData& data, const MapCamera& camera, const Vocabulary& vocabulary,
                        const std::string& source);

// The calling thread's heap prepared for ReadMapFile(`path`) and then
// LoadMapData on this thread (ReserveHeapForMap, map_file.h: huge-page
// memory, 0.8x the file's size made resident ahead of the load by a thread
// of its own). The keyframes' keypoints and descriptors stay in the file's
// mapping, the rest is copied once (docs/mapstore.md): at 10k keyframes the
// load's heap peaks at 0.69 GB of a 1.03 GB file (1.01 GB of a 1.12 GB one
// when the keypoints were copied); the resident head start was 1.1x then,
// and pages made resident beyond the load's need only held the second core
// back from the checksum. Keep it while the load allocates.
HeapReservation ReserveHeapForLoadMap(const std::filesystem::path& path);

// Loads `data` (ValidateMapData-checked) into an empty `map` and `database`.
// Keyframes keep their saved ids, poses, features, bags of words (feature
// vectors are recomputed when `bow_levels_up` differs from the saved one),
// connections, parents and loop edges; map points their ids, positions,
// normals, distances, descriptors, counters and observations. `data` is
// consumed (its arrays move into the map; keypoints and descriptors that
// view a map file, ReadMapFile, stay views: the keyframes keep the file's
// mapping open). Throws DataError naming `source` when `map` is not empty
// or a next id is above CheckMapNextIds' bound (map_file.h: ids index the
// map's arrays).
void LoadMapData(MapData data, const SensorModel& sensor, const Vocabulary& vocabulary,
                 int bow_levels_up, Map* map, KeyFrameDatabase* database,
                 const std::string& source);

}  // namespace rrslam
