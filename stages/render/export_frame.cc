#include "stages/render/export_frame.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <utility>
#include <vector>

#include "common/dataset.h"
#include "common/errors.h"
#include "stages/mapstore/floor.h"
#include "stages/mapstore/map_file.h"
#include "stages/mapstore/map_join.h"
#include "stages/render/ply.h"

namespace rrslam {

void AddFrameOption(CLI::App* command, std::string* frame) {
  command
      ->add_option("--frame", *frame,
                   "camera (the map's world: the first keyframe's camera, y down) or floor (z "
                   "up, origin on the floor: the frame rrslam-mapstore align-floor stored, else "
                   "the floor found now)")
      ->capture_default_str();
}

bool CheckFrameName(const std::string& frame, std::string* why) {
  if (frame == "camera" || frame == "floor") return true;
  *why = "--frame " + frame + ": must be camera or floor";
  return false;
}

std::optional<Rigid3d> ExportFrame(const std::string& frame, const MapData& map,
                                   const std::string& source,
                                   const std::filesystem::path& sequence_dir,
                                   const std::filesystem::path& associations) {
  if (frame == "camera") return std::nullopt;
  std::string why;
  if (!CheckFrameName(frame, &why)) throw UsageError(why);
  if (auto stored = FloorFromMetadata(map.metadata)) return stored;
  std::optional<RgbdSequence> sequence;
  if (!sequence_dir.empty()) {
    SequenceOptions options;
    options.associations = associations;
    sequence = RgbdSequence::Open(sequence_dir, options);
  }
  constexpr int kDepthStride = 8;
  const std::vector<Eigen::Vector3d> points =
      FloorSearchPoints(map, sequence ? &*sequence : nullptr, kDepthStride, source);
  if (auto found = FindFloor(map, points)) {
    spdlog::info(
        "render: floor found among {} of {} points of {} (not stored: rrslam-mapstore "
        "align-floor stores it)",
        found->inliers, found->points, source);
    return found->T_floor_map;
  }
  spdlog::warn("render: no floor found in {}; the camera frame is kept", source);
  return std::nullopt;
}

std::string FrameComment(const std::optional<Rigid3d>& T) {
  if (!T) return kMapFrameComment;
  return fmt::format(
      "frame: floor (REP 103: z up, origin on the floor under the first keyframe, x along its "
      "view), metres; T_floor_map q = ({:.9f} {:.9f} {:.9f} {:.9f}) t = ({:.6f} {:.6f} {:.6f})",
      T->rotation.w(), T->rotation.x(), T->rotation.y(), T->rotation.z(), T->translation.x(),
      T->translation.y(), T->translation.z());
}

FramedMap LoadMapInFrame(const std::filesystem::path& map, const std::string& frame,
                         const std::filesystem::path& sequence,
                         const std::filesystem::path& associations) {
  FramedMap framed;
  framed.data = ReadMapFile(map);
  framed.T_floor_map = ExportFrame(frame, framed.data, map.string(), sequence, associations);
  if (framed.T_floor_map) MoveMap(*framed.T_floor_map, &framed.data);
  framed.scene = MakeMapScene(framed.data, map.string());
  if (framed.T_floor_map) framed.scene.up = Eigen::Vector3d::UnitZ();
  framed.comment = FrameComment(framed.T_floor_map);
  return framed;
}

}  // namespace rrslam
