// DBoW2's own YAML vocabularies, as TemplatedVocabulary::save(filename)
// writes them through OpenCV's cv::FileStorage: `.yml`, or `.yml.gz` when
// the file name asks FileStorage for gzip compression. docs/vocab.md has the
// layout; in short:
//
//   %YAML:1.0
//   ---
//   vocabulary:
//      k: 9
//      L: 4
//      scoringType: 0          (DBoW2's ScoringType: 0 L1 ... 5 dot product)
//      weightingType: 0        (DBoW2's WeightingType: 0 TF-IDF ... 3 binary)
//      nodes:                  (every node but the root, in DBoW2's save order:
//         - { nodeId:1, parentId:0, weight:0.,      a stack walk from the root,
//             descriptor:"45 117 ... 177 " }        not id order)
//      words:
//         - { wordId:0, nodeId:10 }
//
// A descriptor is FORB::toString's text: the 32 bytes in decimal, each
// followed by one space. Node ids are DBoW2's, the ids the text format
// numbers by line. Weights are doubles at full precision; the reader rounds
// each to the 6 significant digits DBoW2's text keeps, then to float32, so
// that a YAML file and the DBoW2 text of the same vocabulary give the same
// VocabularyData node for node (and the same VocabularyContentHash): their
// conversions to text are byte for byte the text DBoW2 writes.
//
// The loader for every format, LoadVocabularyFile, lives here too: it is the
// one rrslam-vocab uses for all its commands. Vocabulary::Load (binary and
// text only) stays free of OpenCV and zlib, because the libFuzzer builds of
// vocabulary.cc and vocabulary_format.cc link neither; it refuses a YAML file
// with a message that says to convert it first.
#pragma once

#include <cstdint>
#include <filesystem>
#include <span>
#include <string>

#include "stages/vocab/vocabulary.h"
#include "stages/vocab/vocabulary_format.h"

namespace rrslam {

// Largest DBoW2 YAML text read, plain or inflated from gzip: 1 GiB. A
// node takes ~240 bytes of YAML (its descriptor in decimal, weight, ids), so
// this is ~4.4 million nodes, four times ORB-SLAM's ORBvoc (k = 10, L = 6,
// 1.1 million nodes, ~250 MB of YAML); one level more (11 million nodes,
// 2.7 GB) is no vocabulary anyone uses, and 10 levels of k = 10 (1.1e10
// nodes) are absurd. A gzip file inflating past it is a bomb, refused as it
// inflates, before anything is allocated for the text.
inline constexpr uint64_t kMaxYamlVocabularyBytes = uint64_t{1} << 30;

// Tests only: lowers the cap above (0 restores it). Not thread-safe.
void SetMaxYamlVocabularyBytesForTesting(uint64_t bytes);

// Parses a DBoW2 YAML vocabulary held in memory, plain or gzip-compressed
// (told by the gzip magic), into arrays in DBoW2 id order. Checks what the
// DBoW2 text parser checks, plus what only YAML can get wrong: every key
// present and of the right type (k in [1, 31], L in [1, 255], scoringType in
// [0, 5], weightingType in [0, 3]), node ids 1 .. N-1 each exactly once,
// parents before their children with siblings consecutive (DBoW2 numbers
// nodes so) and listed in id order, descriptors of exactly 32 decimal bytes,
// finite float32 weights, and a words list naming every leaf once, numbered
// in node order (as DBoW2 numbers them; a vocabulary numbered otherwise
// cannot be kept as binary or DBoW2 text without renumbering). Throws a
// one-line DataError naming `source` and the node at fault (its nodeId and
// its entry in the list: FileStorage gives no line numbers), or the size when
// the text is larger than kMaxYamlVocabularyBytes.
VocabularyData ParseYamlVocabulary(std::span<const uint8_t> bytes, const std::string& source);

// The YAML text DBoW2's save would write for `v` (nodes in its stack order,
// weights as doubles). Throws DataError when `v` is not a tree.
std::string FormatYamlVocabulary(const VocabularyView& v, const std::string& source);

// Writes FormatYamlVocabulary(v) to `path` atomically, gzip-compressed when
// the name ends in ".gz" (as FileStorage would). Throws CantCreateError.
void WriteYamlVocabulary(const std::filesystem::path& path, const VocabularyView& v,
                         const std::string& source);

// True for the names DBoW2 / FileStorage give YAML files: .yml, .yaml,
// .yml.gz, .yaml.gz.
bool HasYamlExtension(const std::filesystem::path& path);

// Loads a vocabulary in any format: binary (.rrv), DBoW2 text or DBoW2 YAML,
// told by content (DetectVocabularyFileFormat); a file named .yml / .yaml /
// .yml.gz / .yaml.gz is read as YAML whatever it holds, so that a broken one
// gets a YAML error. Binary and text go through Vocabulary::Load; a YAML
// vocabulary's checksum() is the XXH3-64 of the file as stored. Sets
// `*format` when non-null. Throws NoInputError when missing, DataError when
// malformed; errors name the file.
Vocabulary LoadVocabularyFile(const std::filesystem::path& path,
                              VocabularyFileFormat* format = nullptr);

}  // namespace rrslam
