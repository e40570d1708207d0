// The frame an export or picture of rrslam-render is written in (`--frame`):
// "camera", the map's own world (its first keyframe's camera: x right, y
// down, z forward), or "floor", REP 103's z up with the origin on the floor
// under the first keyframe (stages/mapstore/floor.h). Every command that
// writes coordinates takes the option, binds it with AddFrameOption, loads
// its map with LoadMapInFrame and names the frame with FrameComment.
//
// Units: metres. T_floor_map maps map-world points into the floor frame.
#pragma once

#include <filesystem>
#include <optional>
#include <string>

#include "common/geometry.h"
#include "stages/mapstore/map_data.h"
#include "stages/render/map_scene.h"

namespace CLI {
class App;
}

namespace rrslam {

// Binds `--frame camera|floor` to `frame` (its value is the default shown).
void AddFrameOption(CLI::App* command, std::string* frame);

// The options' check of a --frame value: false, with `why`, unless it is
// camera or floor.
bool CheckFrameName(const std::string& frame, std::string* why);

// `--frame`: "camera" (nullopt) or "floor": the floor frame the map's
// metadata holds (`rrslam-mapstore align-floor`), else the floor found among
// the map points and, given `sequence` (with `associations` as
// rrslam-track's), the keyframes' depth: a textureless floor has few map
// points, and the synthetic room's points alone give a table for the floor.
// Where no floor is found it says so on stderr and returns nullopt: the
// camera frame is kept. Throws UsageError for another name.
std::optional<Rigid3d> ExportFrame(const std::string& frame, const MapData& map,
                                   const std::string& source,
                                   const std::filesystem::path& sequence = {},
                                   const std::filesystem::path& associations = {});

// The comment naming an export's frame (PLY header, YAML, metadata):
// ply.h's kMapFrameComment for the camera frame, else the floor frame with
// T_floor_map.
std::string FrameComment(const std::optional<Rigid3d>& T_floor_map);

// A map read (mapstore's ReadMapFile: NoInputError, DataError naming the
// file) and moved into the frame `frame` names (ExportFrame).
struct FramedMap {
  MapData data;                        // Poses and points in the export frame.
  MapScene scene;                      // Of `data`.
  std::optional<Rigid3d> T_floor_map;  // nullopt: the camera frame.
  std::string comment;                 // FrameComment(T_floor_map).
  bool floor() const { return T_floor_map.has_value(); }
};
FramedMap LoadMapInFrame(const std::filesystem::path& map, const std::string& frame,
                         const std::filesystem::path& sequence = {},
                         const std::filesystem::path& associations = {});

}  // namespace rrslam
