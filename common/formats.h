// Every file format rrslam writes, with its identity and current version.
//
// Binary formats start with the header of binary_header.h; HDF5 formats carry
// the root attributes of h5io.h. A reader rejects an unknown major version,
// accepts a newer minor version (fields it does not know are ignored), and
// names the file and the versions in its error.
//
// Change log
//   rrslam.features  1.0  per-frame keypoints and ORB descriptors (extract)
//   rrslam.vocab_tree 1.0 hierarchical k-means tree of ORB descriptors (cluster)
//   rrslam.vocabulary 1.0 binary bag-of-words vocabulary (vocab)
//   rrslam.map       1.0  saved SLAM map: keyframes, map points, graph (mapstore)
//                    1.1  other maps kept beside the map
//                    2.0  keypoint records of 32 bytes in extract's Keypoint layout (no
//                         u_right), bag-of-words entries and observations of 12 bytes;
//                         1.x files still read (docs/mapstore.md, "Versions")
#pragma once

#include <cstdint>

namespace rrslam {

struct FormatSpec {
  const char* name;  // Human-readable id, also the HDF5 "format" attribute.
  char magic[9];     // 8 magic bytes of a binary format (plus NUL); "" for HDF5.
  uint16_t major;    // Incompatible changes bump the major version.
  uint16_t minor;    // Compatible additions bump the minor version.
};

inline constexpr FormatSpec kFeaturesFormat = {"rrslam.features", "", 1, 1};
inline constexpr FormatSpec kVocabTreeFormat = {"rrslam.vocab_tree", "", 1, 0};
inline constexpr FormatSpec kVocabularyFormat = {"rrslam.vocabulary", "RRSLVOCB", 1, 1};
inline constexpr FormatSpec kMapFormat = {"rrslam.map", "RRSLMAP1", 2, 0};

}  // namespace rrslam
