// The commands of `rrslam-mapstore`: info, verify, diff, align-floor. Each has an options
// struct (defaults, units, Check) and a Run function; main.cc only binds them
// to CLI11 subcommands.
#pragma once

#include <filesystem>
#include <string>

namespace CLI {
class App;
}

namespace rrslam {

// `info`: header, section table with checksum states, counts, vocabulary,
// camera and metadata of a map file.
struct MapInfoOptions {
  std::filesystem::path map;  // Map file (rrslam.map).
  bool json = false;          // Print JSON instead of "key: value" lines.

  bool Check(std::string* why) const;
};

// `verify`: every checksum and relation of a map file.
struct MapVerifyOptions {
  std::filesystem::path map;

  bool Check(std::string* why) const;
};

// `diff`: map points and keyframes added / removed from map `a` to map `b`.
struct MapDiffOptions {
  std::filesystem::path a;  // Before.
  std::filesystem::path b;  // After.
  // A point counts as the same when the other map has a point within this
  // distance (metres, > 0).
  double radius = 0.05;
  std::filesystem::path json_out;  // When set, the JSON report is written here (atomically).

  bool Check(std::string* why) const;
};

// `align-floor`: finds the map's floor (floor.h) and stores the
// floor-aligned frame in the map file's metadata ("floor"); the map's own
// coordinates are unchanged and the file is rewritten atomically.
struct MapAlignFloorOptions {
  std::filesystem::path map;
  std::filesystem::path sequence;  // With it, the keyframes' depth is searched too.
  int stride = 8;                  // Depth pixels sampled every `stride` (>= 1).

  bool Check(std::string* why) const;
};

struct MapstoreCommands {
  MapInfoOptions info;
  MapVerifyOptions verify;
  MapDiffOptions diff;
  MapAlignFloorOptions align_floor;
  std::string chosen;  // "info", "verify" or "diff".
};
void BindMapstoreCommands(CLI::App& app, MapstoreCommands* commands);
void RunMapstoreCommand(const MapstoreCommands& commands);

// Each throws UsageError for invalid options, NoInputError for a missing map,
// DataError for a malformed one, CantCreateError when an output cannot be
// written, and returns the text it printed on stdout.
// RunMapInfo prints what the header allows even when a section is corrupt,
// then throws DataError naming the first problem.
std::string RunMapInfo(const MapInfoOptions& options);
std::string RunMapVerify(const MapVerifyOptions& options);
std::string RunMapDiff(const MapDiffOptions& options);
// Throws AlgorithmError (exit 75) when no floor is found (the map unchanged).
std::string RunMapAlignFloor(const MapAlignFloorOptions& options);

}  // namespace rrslam
