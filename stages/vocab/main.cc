// rrslam-vocab: builds, converts, inspects and queries bag-of-words vocabularies.
#include <CLI/CLI.hpp>

#include "common/cli.h"
#include "stages/vocab/vocab_tool.h"

int main(int argc, char** argv) {
  rrslam::VocabCommands commands;
  return rrslam::RunTool(
      argc, argv,
      {"vocab",
       "Bag-of-words vocabularies of ORB descriptors. Commands:\n"
       "  build    weighted vocabulary from a tree (rrslam-cluster) and training features\n"
       "  convert  between binary (.rrv), DBoW2 text (.txt, ORB-SLAM2's ORBvoc.txt) and\n"
       "           DBoW2 YAML (.yml, .yml.gz, as DBoW2's save writes it)\n"
       "  info     k, L, weighting, scoring, nodes, words, size, version, checksum state\n"
       "  query    BoW vectors of frames of a features file, and their scores\n"
       "Run `rrslam-vocab <command> --help` for a command's flags."},
      [&](CLI::App& app) { rrslam::BindVocabCommands(app, &commands); },
      [&] { rrslam::RunVocabCommand(commands); });
}
