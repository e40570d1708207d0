// The rule every tool applies to its outputs: an output may not be, contain,
// or lie inside any of the run's inputs, so no run can overwrite or delete
// what it reads (`--out seq` for a sequence folder `seq`, `--out map.rrm`
// for the map it reads, `--out seq/model.ply` inside the sequence read).
//
// Paths are compared canonically (absolute, `..` and symbolic links
// resolved for the parts that exist) and, for files that exist, by device
// and inode, so a hard link or another spelling does not slip past.
#pragma once

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

namespace rrslam {

// A flag and the path it gives ("--map", "room.rrm").
using NamedPath = std::pair<std::string, std::filesystem::path>;

// False, with "<flag> <path> is the <flag> input / lies inside the <flag>
// input <path> / contains the <flag> input <path>" in `why`, when `output`
// breaks the rule for one of `inputs`; empty paths are ignored.
bool CheckOutputNotInput(const NamedPath& output, const std::vector<NamedPath>& inputs,
                         std::string* why);

// The rule for every output of a run, and no two outputs naming the same
// file ("<flag> and <flag> name the same file <path>").
bool CheckOutputs(const std::vector<NamedPath>& outputs, const std::vector<NamedPath>& inputs,
                  std::string* why);

}  // namespace rrslam
