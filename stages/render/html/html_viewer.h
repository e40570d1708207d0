// `rrslam-render html`: one self-contained HTML file with a 3D view of a
// saved map (rrslam.map) that any WebGL browser can open and orbit, with no
// network: the viewer (three.js and stages/render/html/viewer/viewer.js,
// bundled by esbuild at build time) is embedded in the library and written
// into every page, and the page's Content-Security-Policy forbids loading
// anything else.
//
// What the page shows: map points coloured by height (blue low -> red high),
// keyframes as camera frusta (grey for keyframes of a loaded map), the keyframe
// trajectory (white), loop edges (yellow), further trajectories (ground truth
// aligned to the map, estimates) in colours of their own, a floor grid of 1 m
// cells, and an overlay naming the map, the producer and the counts, with a
// legend whose entries switch layers on and off. Mouse: drag orbits,
// right-drag pans, the wheel zooms; R resets the view, T looks down.
//
// The initial view is fixed (viewer.js says it in full): from behind the
// keyframes' mean viewing direction, 30 degrees above the floor, framing the
// map's robust bounding sphere. The view frame (ViewFromMap) has x to the
// screen's right and y up, so a test can predict on which side of the picture
// a part of the map appears.
//
// The page's data (<script type="application/json" id="rrslam-data">), all
// positions in the map's world frame, metres:
//   format "rrslam.viewer", version 1, title, map, producer, options (JSON of
//   HtmlOptions or null), counts {points, keyframes, loaded_points,
//   loaded_keyframes, covisibility_edges, loop_edges, trajectories},
//   camera {fx, fy, cx, cy, width, height},
//   view_from_map: 9 numbers, row-major rotation map -> view frame,
//   points: base64 of little-endian float32 x y z per map point,
//   keyframe_poses: base64 float32, 12 per keyframe: row-major [R | t] of
//     T_world_cam (keyframe order = id order),
//   keyframe_loaded: base64 uint8 flag per keyframe (only when the map has a
//     loaded part),
//   keyframe_trajectory: base64 float32 x y z of keyframe centres by timestamp,
//   loop_edges: base64 uint32 pairs of keyframe indices (each edge once),
//   trajectories: [{name, poses, positions: base64 float32 x y z}].
//
// Thread-safety: functions are reentrant; no shared state.
#pragma once

#include <Eigen/Core>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "common/trajectory.h"
#include "stages/render/map_scene.h"

namespace CLI {
class App;
}

namespace rrslam {

struct HtmlOptions {
  std::filesystem::path map;               // --map: map file (rrslam.map). Required.
  std::vector<std::filesystem::path> gt;   // --gt: TUM ground truths, aligned to the map's
                                           // keyframes (ExpressInMapFrame). Optional.
  std::vector<std::filesystem::path> est;  // --est: TUM trajectories already in the map's
                                           // frame (e.g. CameraTrajectory.txt). Optional.
  std::filesystem::path out;               // --out: the HTML file. Required.
  std::string title;                       // --title: page title; empty = the map's file name.
  std::string frame = "camera";            // --frame: camera or floor (export_frame.h); --est
                                           // trajectories are moved into it.

  // False (and `why` names the option) when map or out is missing, a gt/est
  // entry is empty, or the title holds a line break.
  bool Check(std::string* why) const;
  // The options as the page records them.
  nlohmann::ordered_json ToJson() const;
};

// Adds --map, --gt, --est, --out, --title and --frame to `command` (the `html`
// subcommand).
void BindHtmlOptions(CLI::App* command, HtmlOptions* options);

// The rotation R_view_map from the map's world frame to the viewer's view
// frame: y up = the scene's up when it has one (the floor frame's z), else
// the keyframes' mean up direction (-y of each camera), -z =
// their mean viewing direction (+z of each camera) made horizontal, x = right.
// Falls back to the map frame's own -y (up) and +z (forward) when the
// keyframes do not agree on one (mean vector shorter than 0.3) or there are
// none, and to the map's +x as forward when the viewing direction is
// vertical.
Eigen::Matrix3d ViewFromMap(const MapScene& scene);

// The whole page. `trajectories_in_map_frame`: (legend name, poses already in
// the map's frame), drawn in order in the viewer's palette. `title` and
// `producer` are shown (HTML-escaped); `options`, when not null, is recorded
// in the page's data.
std::string BuildViewerHtml(
    const MapScene& scene,
    const std::vector<std::pair<std::string, Trajectory>>& trajectories_in_map_frame,
    const std::string& title, const std::string& producer,
    const nlohmann::ordered_json& options = nullptr);

// Reads the map and the trajectories, builds the page and writes it
// atomically. Throws UsageError for invalid options, NoInputError for a missing
// input, DataError for a malformed one (or a ground truth that cannot be
// aligned to the keyframes), CantCreateError when the page cannot be written;
// messages name the file.
void RunHtml(const HtmlOptions& options);

// The embedded viewer script (bundle of viewer.js and three.js), as built.
std::string_view ViewerScript();

}  // namespace rrslam
