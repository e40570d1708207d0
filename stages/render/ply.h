// Point clouds as PLY files (Stanford polygon format, as MeshLab,
// CloudCompare and Open3D read them), ASCII or binary little-endian.
//
// Written vertex properties, in this order and only when present:
//   float x y z                      position (the map's world frame, metres)
//   float nx ny nz                   normal (unit)
//   uchar red green blue             colour (sRGB)
//   int scalar_observations          keyframes that observe the point (the
//                                    scalar_ prefix: CloudCompare keeps such
//                                    properties as scalar fields and drops
//                                    others; read back under either name)
// and, when faces are given, `element face` with `property list uchar int
// vertex_indices` (triangles).
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace rrslam {

enum class PlyFormat { kAscii, kBinaryLittleEndian };

struct PlyCloud {
  std::vector<Eigen::Vector3f> positions;
  std::vector<Eigen::Vector3f> normals;           // Empty or one per position.
  std::vector<std::array<uint8_t, 3>> colors;     // RGB; empty or one per position.
  std::vector<int32_t> observations;              // Empty or one per position.
  std::vector<std::array<int32_t, 3>> triangles;  // Vertex indices; may be empty.
  std::vector<std::string> comments;              // Header comments (one line each).
};

// The header comment that names the frame of rrslam's clouds.
inline constexpr const char* kMapFrameComment =
    "frame: map world = the first keyframe's camera (x right, y down, z forward), metres";

// Serializes a cloud. Throws std::invalid_argument when a per-vertex array
// has the wrong length, a triangle index is out of range or a comment holds a
// line break.
std::string EncodePly(const PlyCloud& cloud, PlyFormat format);

// Writes a cloud atomically (common/atomic_file.h). Throws CantCreateError.
void WritePly(const std::filesystem::path& path, const PlyCloud& cloud, PlyFormat format);

// Reads a PLY file in either format with the properties above (others of the
// vertex element are skipped; x, y, z are required; float or double
// positions). Throws NoInputError when it cannot be opened, DataError naming
// the file and the problem when it is not such a PLY file.
PlyCloud ReadPly(const std::filesystem::path& path);
PlyCloud ParsePly(const std::string& bytes, const std::string& source);

}  // namespace rrslam
