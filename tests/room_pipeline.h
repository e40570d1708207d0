// What the end-to-end tests share: a small synthetic room sequence with a
// vocabulary trained on it, made by the real executables.
#pragma once

#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

#include "common/atomic_file.h"
#include "common/testing.h"

namespace rrslam::testing {

// Renders sequence DIR/room with rrslam-synth `synth_args` (320 x 240 keeps
// rendering and extraction quick) and trains DIR/room.rrv on it
// (rrslam-extract -> rrslam-cluster k = 8, L = 3 -> rrslam-vocab build).
// Fails the test (ASSERT) when a tool fails.
inline void PrepareRoomSequence(const std::filesystem::path& dir, const std::string& synth_args) {
  auto run = [](const std::string& stage, const std::string& args) {
    const auto r = RunTool(stage, "--quiet " + args);
    ASSERT_EQ(r.exit_code, 0) << "rrslam-" << stage << " " << args << "\n" << r.output;
  };
  const std::filesystem::path seq = dir / "room", features = dir / "room.h5";
  run("synth", "--out " + Quote(seq) + " --width 320 --height 240 " + synth_args);
  run("extract", "--sequence " + Quote(seq) + " --settings " + Quote(seq / "settings.yaml") +
                     " --out " + Quote(features));
  run("cluster",
      "--features " + Quote(features) + " --out " + Quote(dir / "tree.h5") + " --k 8 -L 3");
  run("vocab", "build --tree " + Quote(dir / "tree.h5") + " --features " + Quote(features) +
                   " --out " + Quote(dir / "room.rrv"));
}

// A JSON file (run.json, synth.json, reports) parsed.
inline nlohmann::json ReadJson(const std::filesystem::path& path) {
  return nlohmann::json::parse(ReadFileToString(path));
}

}  // namespace rrslam::testing
