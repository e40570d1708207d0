// rrslam-extract: ORB features of an RGB-D sequence into a features file.
#include <CLI/CLI.hpp>

#include "common/cli.h"
#include "stages/extract/extract.h"

namespace {

void BindExtractOptions(CLI::App& app, rrslam::ExtractOptions* options) {
  app.add_option("--sequence", options->sequence,
                 "TUM RGB-D sequence folder (rgb.txt + depth.txt, or associations.txt)")
      ->required();
  app.add_option("--settings", options->settings,
                 "ORB-SLAM2 RGB-D settings YAML (camera, DepthMapFactor, ORBextractor.*)")
      ->required();
  app.add_option("--out", options->out, "Features file to write (HDF5, rrslam.features)")
      ->required();
  app.add_option("--associations", options->associations,
                 "Associations file 'rgb_ts rgb_path depth_ts depth_path' (relative to the "
                 "sequence folder or absolute); default: pair rgb.txt with depth.txt")
      ->capture_default_str();
  app.add_option("--stride", options->stride, "Take every N-th paired frame (>= 1)")
      ->capture_default_str();
  app.add_option("--first", options->first, "Index of the first paired frame taken (>= 0)")
      ->capture_default_str();
  app.add_option("--max-frames", options->max_frames, "Take at most N frames (0 = all)")
      ->capture_default_str();
  app.add_option("--threads", options->threads,
                 "Worker threads (0 = one per core); the output does not depend on it")
      ->capture_default_str();
}

}  // namespace

int main(int argc, char** argv) {
  rrslam::ExtractOptions options;
  return rrslam::RunTool(
      argc, argv,
      {"extract",
       "Extracts ORB features (ORB-SLAM2's operator: pyramid, FAST on grid cells, quadtree "
       "distribution, rotated BRIEF) from every selected frame of a TUM RGB-D sequence, "
       "undistorts them and attaches depth, and writes an HDF5 features file."},
      [&](CLI::App& app) { BindExtractOptions(app, &options); }, [&] { RunExtract(options); });
}
