// The commands of `rrslam-vocab`: build, convert, info, query. Each has an
// options struct (defaults, units, Check) and a Run function; main.cc only
// binds them to CLI11 subcommands.
#pragma once

#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace CLI {
class App;
}

namespace rrslam {

// `build`: a vocabulary from a tree and the training features.
struct VocabBuildOptions {
  std::filesystem::path tree;                   // rrslam-cluster output (HDF5).
  std::vector<std::filesystem::path> features;  // Training features files (>= 1).
  // Output: binary (.rrv), DBoW2 text (.txt) or DBoW2 YAML (.yml, .yml.gz),
  // told by the extension.
  std::filesystem::path out;
  std::string weighting = "tf-idf";  // tf-idf, tf, idf or binary.
  std::string scoring = "l1";        // l1, l2, chi-square, kl, bhattacharyya or dot-product.
  // Every `stride`-th frame of each features file is a training image (>= 1);
  // use the stride given to rrslam-cluster.
  int stride = 1;
  // Worker threads, 0 = all; in [0, kMaxThreads = 256] (common/worker_pool.h).
  // Does not change the result.
  int threads = 0;

  bool Check(std::string* why) const;
  nlohmann::json ToJson() const;
};

// `convert`: between binary, DBoW2 text and DBoW2 YAML; the input format is
// told by content (LoadVocabularyFile), the output format by the extension
// of `out` (.rrv binary, .txt text, .yml / .yaml YAML, .yml.gz / .yaml.gz
// gzip-compressed YAML).
struct VocabConvertOptions {
  std::filesystem::path in;
  std::filesystem::path out;

  bool Check(std::string* why) const;
};

// `info`: header facts of a vocabulary, and whether its checksum holds.
struct VocabInfoOptions {
  std::filesystem::path file;
  bool json = false;  // Print JSON instead of "key: value" lines.

  bool Check(std::string* why) const;
};

// `query`: BoW vectors of frames of a features file, and their scores.
struct VocabQueryOptions {
  std::filesystem::path vocab;     // Vocabulary (.rrv, DBoW2 .txt or .yml[.gz]).
  std::filesystem::path features;  // Features file (rrslam-extract output).
  // Frame indices (0-based, >= 1 of them). With two or more, the first is
  // scored against each of the others.
  std::vector<int64_t> frames;
  bool all = false;           // Score the first frame against every frame of the file.
  int levels_up = 4;          // Feature vector grouping (levels above the leaves), >= 0.
  bool json = false;          // JSON output instead of text.
  std::filesystem::path out;  // Write the output here (atomically) instead of stdout.

  bool Check(std::string* why) const;
};

// Binds the four subcommands with their flags to `app`; after parsing,
// RunVocabCommand runs the one given.
struct VocabCommands {
  VocabBuildOptions build;
  VocabConvertOptions convert;
  VocabInfoOptions info;
  VocabQueryOptions query;
  std::string chosen;  // "build", "convert", "info" or "query".
};
void BindVocabCommands(CLI::App& app, VocabCommands* commands);
void RunVocabCommand(const VocabCommands& commands);

// Each throws UsageError for invalid options, NoInputError / DataError for bad
// inputs, CantCreateError when an output cannot be written. Every command
// loads vocabularies with LoadVocabularyFile (vocabulary_yaml.h), so each
// reads all three formats.
void RunVocabBuild(const VocabBuildOptions& options);
void RunVocabConvert(const VocabConvertOptions& options);
// Returns the text printed (also printed to stdout). Throws DataError after
// printing when the checksum or the structure of the file is wrong.
std::string RunVocabInfo(const VocabInfoOptions& options);
// Returns the output (also written to stdout or options.out).
std::string RunVocabQuery(const VocabQueryOptions& options);

}  // namespace rrslam
