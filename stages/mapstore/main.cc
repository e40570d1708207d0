// rrslam-mapstore: inspects, verifies, compares and merges saved SLAM maps
// (rrslam.map). `merge` is track's (stages/track/map_merge_command.h): it
// needs track's matching and bundle adjustment.
#include <CLI/CLI.hpp>

#include "common/cli.h"
#include "stages/mapstore/mapstore_tool.h"
#include "stages/track/map_merge_command.h"

int main(int argc, char** argv) {
  rrslam::MapstoreCommands commands;
  rrslam::MapMergeCommandOptions merge;
  return rrslam::RunTool(
      argc, argv,
      {"mapstore",
       "Saved SLAM maps (rrslam.map, written by rrslam-track --save-map). Commands:\n"
       "  info    version, size, sections with checksum state, counts, vocabulary, camera,\n"
       "          metadata (works on a file with corrupt sections; exits 65 after printing)\n"
       "  verify  every checksum and relation; prints 'MAP: ok (N keyframes, M map points)'\n"
       "  diff    map points (within --radius) and keyframes added / removed from A to B\n"
       "  align-floor  the floor found; the floor-aligned frame (z up) stored in the map\n"
       "  merge   map B moved into map A's frame where they overlap, welded, saved as --out\n"
       "          (exit 75 when no overlap is found)\n"
       "Run `rrslam-mapstore <command> --help` for a command's flags."},
      [&](CLI::App& app) {
        rrslam::BindMapstoreCommands(app, &commands);
        rrslam::BindMapMergeCommand(app, &merge, &commands.chosen);
      },
      [&] {
        if (commands.chosen == "merge") {
          rrslam::RunMapMerge(merge);
        } else {
          rrslam::RunMapstoreCommand(commands);
        }
      });
}
