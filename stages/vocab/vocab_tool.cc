#include "stages/vocab/vocab_tool.h"

#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <cinttypes>
#include <cstdio>
#include <iostream>
#include <sstream>

#include "common/atomic_file.h"
#include "common/binary_header.h"
#include "common/cli.h"
#include "common/errors.h"
#include "common/formats.h"
#include "common/json_text.h"
#include "common/output_path.h"
#include "common/progress.h"
#include "common/text.h"
#include "common/worker_pool.h"
#include "stages/cluster/vocab_tree.h"
#include "stages/extract/features_file.h"
#include "stages/vocab/vocab_build.h"
#include "stages/vocab/vocabulary.h"
#include "stages/vocab/vocabulary_format.h"
#include "stages/vocab/vocabulary_yaml.h"

namespace rrslam {
namespace {

bool Fail(std::string* why, const std::string& text) {
  if (why != nullptr) *why = text;
  return false;
}

enum class FileKind { kBinary, kText, kYaml, kUnknown };

FileKind KindByExtension(const std::filesystem::path& path) {
  const std::string ext = path.extension().string();
  if (ext == ".rrv") return FileKind::kBinary;
  if (ext == ".txt") return FileKind::kText;
  if (HasYamlExtension(path)) return FileKind::kYaml;
  return FileKind::kUnknown;
}

constexpr char kOutputExtensions[] =
    "must end in .rrv (binary), .txt (DBoW2 text) or .yml / .yml.gz (DBoW2 YAML)";

double Seconds(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// Writes a vocabulary in the format named by the extension of `path`.
void WriteVocabulary(const std::filesystem::path& path, const VocabularyView& view,
                     const std::string& source) {
  const FileKind kind = KindByExtension(path);
  if (kind == FileKind::kText) {
    WriteTextVocabulary(path, view, source);
  } else if (kind == FileKind::kYaml) {
    WriteYamlVocabulary(path, view, source);
  } else {
    WriteBinaryVocabulary(path, view);
  }
}

void Emit(const std::string& text, const std::filesystem::path& out) {
  if (out.empty()) {
    std::cout << text << std::flush;
  } else {
    WriteFileAtomically(out, text);
  }
}

}  // namespace

// ---------------------------------------------------------------------------
// Options

bool VocabBuildOptions::Check(std::string* why) const {
  WeightingType w;
  ScoringType s;
  if (tree.empty()) return Fail(why, "tree: a vocabulary tree file is required");
  if (features.empty()) return Fail(why, "features: at least one features file is required");
  if (out.empty()) return Fail(why, "out: an output file is required");
  if (KindByExtension(out) == FileKind::kUnknown) {
    return Fail(why, "out = " + out.string() + "; " + kOutputExtensions);
  }
  std::vector<NamedPath> inputs = {{"--tree", tree}};
  for (const auto& f : features) inputs.push_back({"--features", f});
  if (!CheckOutputNotInput({"--out", out}, inputs, why)) return false;
  if (!ParseWeighting(weighting, &w)) {
    return Fail(why, "weighting = " + weighting + "; must be tf-idf, tf, idf or binary");
  }
  if (!ParseScoring(scoring, &s)) {
    return Fail(why, "scoring = " + scoring +
                         "; must be l1, l2, chi-square, kl, bhattacharyya or dot-product");
  }
  if (stride < 1) return Fail(why, "stride = " + std::to_string(stride) + "; must be >= 1");
  if (threads < 0 || threads > kMaxThreads) {
    return Fail(why, "threads = " + std::to_string(threads) + "; must be in [0, " +
                         std::to_string(kMaxThreads) + "] (0 = all cores)");
  }
  return true;
}

nlohmann::json VocabBuildOptions::ToJson() const {
  nlohmann::json files = nlohmann::json::array();
  for (const auto& f : features) files.push_back(f.string());
  return {{"tree", tree.string()},  {"features", files},  {"out", out.string()},
          {"weighting", weighting}, {"scoring", scoring}, {"stride", stride},
          {"threads", threads}};
}

bool VocabConvertOptions::Check(std::string* why) const {
  if (in.empty()) return Fail(why, "in: an input vocabulary is required");
  if (out.empty()) return Fail(why, "out: an output file is required");
  if (KindByExtension(out) == FileKind::kUnknown) {
    return Fail(why, "out = " + out.string() + "; " + kOutputExtensions);
  }
  return CheckOutputNotInput({"out", out}, {{"in", in}}, why);
}

bool VocabInfoOptions::Check(std::string* why) const {
  if (file.empty()) return Fail(why, "file: a vocabulary file is required");
  return true;
}

bool VocabQueryOptions::Check(std::string* why) const {
  if (vocab.empty()) return Fail(why, "vocab: a vocabulary file is required");
  if (features.empty()) return Fail(why, "features: a features file is required");
  if (frames.empty()) return Fail(why, "frames: at least one --frame is required");
  for (int64_t f : frames) {
    if (f < 0) return Fail(why, "frames: frame " + std::to_string(f) + " is negative");
  }
  if (levels_up < 0) {
    return Fail(why, "levels_up = " + std::to_string(levels_up) + "; must be >= 0");
  }
  return CheckOutputNotInput({"--out", out}, {{"--vocab", vocab}, {"--features", features}}, why);
}

// ---------------------------------------------------------------------------
// CLI

void BindVocabCommands(CLI::App& app, VocabCommands* c) {
  app.require_subcommand(1);
  CLI::App* build = app.add_subcommand("build", "Builds a weighted vocabulary from a tree");
  build->add_option("--tree", c->build.tree, "Vocabulary tree (rrslam-cluster output)")->required();
  build->add_option("--features", c->build.features, "Training features files")
      ->required()
      ->expected(1, -1);
  build->add_option("--out", c->build.out, "Output vocabulary: .rrv (binary) or .txt (DBoW2)")
      ->required();
  build->add_option("--weighting", c->build.weighting, "tf-idf, tf, idf or binary")
      ->capture_default_str();
  build
      ->add_option("--scoring", c->build.scoring,
                   "l1, l2, chi-square, kl, bhattacharyya or dot-product")
      ->capture_default_str();
  build
      ->add_option("--stride", c->build.stride,
                   "Every N-th frame is a training image (as given to rrslam-cluster)")
      ->capture_default_str();
  build->add_option("--threads", c->build.threads, "Worker threads, in [0, 256], 0 = all cores")
      ->capture_default_str();
  build->callback([c] { c->chosen = "build"; });

  CLI::App* convert = app.add_subcommand(
      "convert",
      "Converts between binary (.rrv), DBoW2 text (.txt) and DBoW2 YAML (.yml, .yml.gz) "
      "vocabularies");
  convert
      ->add_option("in", c->convert.in,
                   "Input vocabulary: binary, DBoW2 text or DBoW2 YAML (plain or gzip), told by "
                   "content")
      ->required();
  convert
      ->add_option("out", c->convert.out,
                   "Output vocabulary, told by extension: .rrv, .txt, .yml or .yml.gz")
      ->required();
  convert->callback([c] { c->chosen = "convert"; });

  CLI::App* info = app.add_subcommand("info", "Prints a vocabulary's header and checksum state");
  info->add_option("file", c->info.file, "Vocabulary (.rrv, DBoW2 text or YAML)")->required();
  info->add_flag("--json", c->info.json, "Print JSON");
  info->callback([c] { c->chosen = "info"; });

  CLI::App* query = app.add_subcommand(
      "query", "Prints BoW vectors of frames of a features file and their scores");
  query->add_option("--vocab", c->query.vocab, "Vocabulary (.rrv, DBoW2 text or YAML)")->required();
  query->add_option("--features", c->query.features, "Features file")->required();
  query
      ->add_option("--frame", c->query.frames,
                   "Frame index (repeat: the first is scored against the others)")
      ->required();
  query->add_flag("--all", c->query.all, "Score the first frame against every frame");
  query
      ->add_option("--levels-up", c->query.levels_up,
                   "Feature vector grouping, levels above the leaves")
      ->capture_default_str();
  query->add_flag("--json", c->query.json, "Print JSON");
  query->add_option("--out", c->query.out, "Write the output to this file instead of stdout");
  query->callback([c] { c->chosen = "query"; });
}

void RunVocabCommand(const VocabCommands& c) {
  if (c.chosen == "build") {
    RunVocabBuild(c.build);
  } else if (c.chosen == "convert") {
    RunVocabConvert(c.convert);
  } else if (c.chosen == "info") {
    RunVocabInfo(c.info);
  } else if (c.chosen == "query") {
    RunVocabQuery(c.query);
  } else {
    throw UsageError("a command is required: build, convert, info or query");
  }
}

// ---------------------------------------------------------------------------
// build

void RunVocabBuild(const VocabBuildOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw UsageError(why);
  const auto start = std::chrono::steady_clock::now();
  WeightingType weighting;
  ScoringType scoring;
  ParseWeighting(options.weighting, &weighting);
  ParseScoring(options.scoring, &scoring);

  H5FormatInfo tree_info;
  const VocabTree tree = ReadVocabTree(options.tree, &tree_info);
  VocabularyData data = VocabularyFromTree(tree, weighting, scoring, options.tree.string());

  std::vector<FeaturesFile> files;
  std::vector<std::span<const OrbDescriptor>> images;
  for (const auto& path : options.features) {
    files.push_back(ReadFeaturesFile(path));
  }
  for (const FeaturesFile& f : files) {
    for (size_t frame = 0; frame < f.num_frames(); frame += static_cast<size_t>(options.stride)) {
      images.push_back(f.FrameDescriptors(frame));
    }
  }
  if (images.empty()) throw DataError("the features files hold no frame: no training image");
  {
    ProgressBar progress("vocab build", images.size(), "img");
    SetWordWeights(images, options.threads, &data, &progress);
  }
  size_t unseen = 0;
  for (size_t i = 1; i < data.info.num_nodes; ++i) {
    unseen += LinkChildren(data.links()[i]) == 0 && data.weights()[i] == 0;
  }
  if (unseen > 0) {
    spdlog::info("vocab build: {} of {} words have weight 0 (in no or in every training image)",
                 unseen, data.info.num_words);
  }
  nlohmann::json metadata = {{"producer", Producer("vocab")},
                             {"command", "build"},
                             {"options", options.ToJson()},
                             {"training_images", images.size()},
                             {"tree",
                              {{"file", options.tree.string()},
                               {"producer", tree_info.producer},
                               {"options", tree_info.options}}}};
  data.metadata = DumpJson(metadata);
  WriteVocabulary(options.out, data.view(), options.out.string());
  spdlog::info("vocab build: k={} L={} {} nodes, {} words, {} images, {} / {} in {:.2f} s -> {}",
               data.info.k, data.info.levels, data.info.num_nodes, data.info.num_words,
               images.size(), options.weighting, options.scoring, Seconds(start),
               options.out.string());
}

// ---------------------------------------------------------------------------
// convert

void RunVocabConvert(const VocabConvertOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw UsageError(why);
  const auto start = std::chrono::steady_clock::now();
  VocabularyFileFormat format;
  const Vocabulary vocabulary = LoadVocabularyFile(options.in, &format);
  const double load_seconds = Seconds(start);
  VocabularyView view = vocabulary.view();
  std::string metadata;
  if (KindByExtension(options.out) == FileKind::kBinary && !vocabulary.is_binary()) {
    metadata = DumpJson(nlohmann::json{
        {"producer", Producer("vocab")},
        {"command", "convert"},
        {"converted_from", options.in.filename().string()},
        {"source_format", format == VocabularyFileFormat::kDbow2Yaml ? "dbow2-yaml" : "dbow2-text"},
        {"source_checksum", Hex64(vocabulary.checksum())}});
    view.metadata = metadata;
  }
  WriteVocabulary(options.out, view, options.in.string());
  spdlog::info("vocab convert: {} ({}, loaded in {:.3f} s) -> {} in {:.2f} s", options.in.string(),
               VocabularyFileFormatName(format), load_seconds, options.out.string(),
               Seconds(start));
}

// ---------------------------------------------------------------------------
// info

std::string RunVocabInfo(const VocabInfoOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw UsageError(why);
  const std::string name = options.file.string();
  std::error_code ec;
  if (!std::filesystem::exists(options.file, ec)) throw NoInputError(name + ": file not found");
  nlohmann::ordered_json j;
  j["file"] = name;
  std::string problem;
  const MappedFile file(options.file);
  j["size_bytes"] = file.bytes().size();
  if (HasMagic(file.bytes(), kVocabularyFormat)) {
    const BinaryVocabularyHeader h = ParseBinaryVocabularyHeader(file.bytes(), name);
    j["format"] = std::string(kVocabularyFormat.name) + " " + std::to_string(h.major) + "." +
                  std::to_string(h.minor) + " (binary)";
    j["k"] = h.info.k;
    j["levels"] = h.info.levels;
    j["weighting"] = WeightingName(h.info.weighting);
    j["scoring"] = ScoringName(h.info.scoring);
    j["nodes"] = h.info.num_nodes;
    j["words"] = h.info.num_words;
    // One pass over the payload when the file is sound (the parse verifies
    // the checksum first); a second only to say what failed.
    try {
      const VocabularyView v = ParseBinaryVocabulary(file.bytes(), name);
      j["checksum"] = "ok (xxh3 " + Hex64(h.payload_checksum) + ")";
      j["structure"] = "ok";
      j["tree"] = Hex64(TreeHashOf(v, h)) + (h.tree_hash != 0 ? " (stored)" : " (computed)");
      nlohmann::json metadata = nlohmann::json::parse(v.metadata, nullptr, false);
      if (!v.metadata.empty()) {
        j["metadata"] =
            metadata.is_discarded() ? nlohmann::json(std::string(v.metadata)) : metadata;
      }
    } catch (const DataError& e) {
      const BinaryHeaderView base = ParseBinaryHeader(file.bytes(), kVocabularyFormat, name);
      const uint64_t actual = Checksum64(base.payload);
      if (actual != h.payload_checksum) {
        j["checksum"] =
            "MISMATCH (header " + Hex64(h.payload_checksum) + ", payload " + Hex64(actual) + ")";
        problem = name + ": corrupt payload (checksum mismatch)";
      } else {
        j["checksum"] = "ok (xxh3 " + Hex64(actual) + ")";
        j["structure"] = e.what();
        problem = e.what();
      }
    }
  } else {
    VocabularyFileFormat format;
    const Vocabulary v = LoadVocabularyFile(options.file, &format);
    const std::string format_name = VocabularyFileFormatName(format);
    j["format"] = format_name;
    j["k"] = v.k();
    j["levels"] = v.levels();
    j["weighting"] = WeightingName(v.weighting());
    j["scoring"] = ScoringName(v.scoring());
    j["nodes"] = v.num_nodes();
    j["words"] = v.num_words();
    j["checksum"] = "none in " + format_name + " (xxh3 of the file " + Hex64(v.checksum()) + ")";
    j["structure"] = "ok";
    j["tree"] = Hex64(v.content_hash());
  }
  std::string text;
  if (options.json) {
    text = DumpJson(j, 2) + "\n";
  } else {
    for (const auto& [key, value] : j.items()) {
      text += key + ": " + (value.is_string() ? value.get<std::string>() : DumpJson(value)) + "\n";
    }
  }
  std::cout << text << std::flush;
  if (!problem.empty()) throw DataError(problem);
  return text;
}

// ---------------------------------------------------------------------------
// query

std::string RunVocabQuery(const VocabQueryOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw UsageError(why);
  const Vocabulary vocabulary = LoadVocabularyFile(options.vocab);
  const FeaturesFile features = ReadFeaturesFile(options.features);
  const size_t num_frames = features.num_frames();
  for (int64_t f : options.frames) {
    if (static_cast<uint64_t>(f) >= num_frames) {
      throw UsageError("frame " + std::to_string(f) +
                       " is out of range: " + options.features.string() + " has " +
                       std::to_string(num_frames) + " frames");
    }
  }
  std::vector<size_t> shown(options.frames.begin(), options.frames.end());
  std::vector<size_t> others;
  if (options.all) {
    for (size_t f = 0; f < num_frames; ++f) others.push_back(f);
  } else {
    others.assign(shown.begin() + 1, shown.end());
  }
  // BoW vectors of every frame that is shown or scored.
  std::vector<BowVector> bow(num_frames);
  std::vector<FeatureVector> fv(num_frames);
  std::vector<uint8_t> done(num_frames, 0);
  auto transform = [&](size_t f) {
    if (done[f]) return;
    vocabulary.Transform(features.FrameDescriptors(f), &bow[f], &fv[f], options.levels_up);
    done[f] = 1;
  };
  for (size_t f : shown) transform(f);
  for (size_t f : others) transform(f);

  nlohmann::ordered_json j;
  j["vocabulary"] = vocabulary.Identity();
  j["features"] = options.features.string();
  j["frames"] = nlohmann::json::array();
  for (size_t f : shown) {
    nlohmann::ordered_json frame;
    frame["frame"] = f;
    frame["rgb_timestamp"] = features.frames[f].rgb_timestamp;
    frame["features"] = features.FrameDescriptors(f).size();
    frame["words"] = bow[f].size();
    nlohmann::json entries = nlohmann::json::array();
    for (const auto& [word, value] : bow[f].entries) entries.push_back({word, value});
    frame["bow"] = entries;
    nlohmann::json groups = nlohmann::json::array();
    for (const auto& [node, indices] : fv[f].entries) groups.push_back({node, indices.size()});
    frame["feature_vector"] = groups;
    j["frames"].push_back(frame);
  }
  const size_t first = shown.front();
  nlohmann::json scores = nlohmann::json::array();
  for (size_t other : others) {
    scores.push_back(
        {{"a", first}, {"b", other}, {"score", vocabulary.Score(bow[first], bow[other])}});
  }
  j["scores"] = scores;

  std::string text;
  if (options.json) {
    text = DumpJson(j, 2) + "\n";
  } else {
    std::ostringstream s;
    s << "vocabulary: " << vocabulary.Identity() << "\n";
    for (const auto& frame : j["frames"]) {
      s << "frame " << frame["frame"].get<size_t>() << " (t=" << frame["rgb_timestamp"].dump()
        << "): " << frame["features"].get<size_t>() << " features, " << frame["words"].get<size_t>()
        << " words, " << frame["feature_vector"].size() << " feature-vector nodes\n  bow:";
      for (const auto& e : frame["bow"])
        s << " " << e[0].get<WordId>() << ":" << e[1].get<double>();
      s << "\n";
    }
    for (const auto& sc : scores) {
      s << "score " << sc["a"].get<size_t>() << " " << sc["b"].get<size_t>() << " "
        << sc["score"].get<double>() << "\n";
    }
    text = s.str();
  }
  Emit(text, options.out);
  return text;
}

}  // namespace rrslam
