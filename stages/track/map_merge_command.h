// `rrslam-mapstore merge A.rrm B.rrm --vocab V --settings S --out C.rrm`:
// two saved maps of one place as one, in A's world frame (module/
// map_merger.h has the steps). Lives in track, not mapstore, because the
// overlap is found and the maps welded with track's matching and bundle
// adjustment; rrslam-mapstore binds it beside info, verify and diff.
#pragma once

#include <filesystem>
#include <string>

namespace CLI {
class App;
}

namespace rrslam {

struct MapMergeCommandOptions {
  std::filesystem::path a;    // The map whose world frame the result keeps.
  std::filesystem::path b;    // The map moved into it.
  std::filesystem::path out;  // The merged map (written atomically; not A or B).
  // The vocabulary both maps were made with (their bags of words are scored
  // with it) and the settings (camera, depth noise of the bundle
  // adjustment): both maps must match both, as rrslam-track --load-map asks.
  std::filesystem::path vocabulary;
  std::filesystem::path settings;

  bool Check(std::string* why) const;
};

void BindMapMergeCommand(CLI::App& app, MapMergeCommandOptions* options, std::string* chosen);

// Throws UsageError for invalid options, NoInputError for a missing input,
// DataError when a map is malformed or the maps differ in camera or
// vocabulary (or from --settings / --vocab), AlgorithmError (exit 75) when
// no overlap is found, CantCreateError when the output cannot be written.
// Returns the text printed on stdout: the transform, the keyframes matched,
// the points fused and the merged map's counts.
std::string RunMapMerge(const MapMergeCommandOptions& options);

}  // namespace rrslam
