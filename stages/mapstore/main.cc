// rrslam-mapstore: inspects, verifies and compares saved SLAM maps (rrslam.map).
#include <CLI/CLI.hpp>

#include "common/cli.h"
#include "stages/mapstore/mapstore_tool.h"

int main(int argc, char** argv) {
  rrslam::MapstoreCommands commands;
  return rrslam::RunTool(
      argc, argv,
      {"mapstore",
       "Saved SLAM maps (rrslam.map, written by rrslam-track --save-map). Commands:\n"
       "  info    version, size, sections with checksum state, counts, vocabulary, camera,\n"
       "          metadata (works on a file with corrupt sections; exits 65 after printing)\n"
       "  verify  every checksum and relation; prints 'MAP: ok (N keyframes, M map points)'\n"
       "  diff    map points (within --radius) and keyframes added / removed from A to B\n"
       "Run `rrslam-mapstore <command> --help` for a command's flags."},
      [&](CLI::App& app) { rrslam::BindMapstoreCommands(app, &commands); },
      [&] { rrslam::RunMapstoreCommand(commands); });
}
