// rrslam-render: pictures, standard files and a browser viewer of saved maps
// and trajectories, a dense model, a COLMAP model, an OctoMap and a
// navigation grid.
#include <CLI/CLI.hpp>

#include "common/cli.h"
#include "stages/render/render_tool.h"

int main(int argc, char** argv) {
  rrslam::RenderCommands commands;
  return rrslam::RunTool(
      argc, argv,
      {"render",
       "Looks at a run after it ended. Commands:\n"
       "  map         PNG views of a saved map (top, side, front, perspective): points,\n"
       "              keyframe frusta, trajectory, spanning tree, scale bar, axis labels\n"
       "  trajectory  TUM trajectories against the ground truth: top/side/front views with\n"
       "              the error coloured along the path, and the error over time\n"
       "  ply         map points as PLY (MeshLab, CloudCompare), coloured from the images\n"
       "  html        one offline HTML file with a 3D view of the map you can orbit\n"
       "  dense       the keyframes' depth fused into a TSDF: coloured PLY and a PNG\n"
       "  colmap      a COLMAP sparse model (cameras, images, points3D) with the keyframe\n"
       "              images, for Gaussian splatting, NeRF and MVS tools\n"
       "  octomap     the keyframes' depth as an OctoMap (.bt), floor-aligned, for robots\n"
       "  grid        a 2D occupancy grid for navigation (ROS map_server / Nav2 YAML + PGM)\n"
       "              and its picture with the keyframe trajectory\n"
       "Coordinates: --frame camera (the first keyframe's camera) or floor (z up, on the\n"
       "floor: rrslam-mapstore align-floor stores it); octomap and grid use floor.\n"
       "Run `rrslam-render <command> --help` for a command's flags."},
      [&](CLI::App& app) { rrslam::BindRenderCommands(app, &commands); },
      [&] { rrslam::RunRenderCommand(commands); });
}
