#include "stages/render/ply.h"

#include <fmt/format.h>

#include <bit>
#include <cstring>
#include <sstream>
#include <stdexcept>
#include <utility>

#include "common/atomic_file.h"
#include "common/errors.h"

namespace rrslam {
namespace {

static_assert(std::endian::native == std::endian::little, "PLY binary I/O assumes little-endian");

template <typename T>
void Append(std::string* out, T value) {
  char bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));
  out->append(bytes, sizeof(T));
}

void CheckCloud(const PlyCloud& cloud) {
  const size_t n = cloud.positions.size();
  const auto check = [n](size_t size, const char* what) {
    if (size != 0 && size != n) {
      throw std::invalid_argument(fmt::format("PLY {}: {} values for {} vertices", what, size, n));
    }
  };
  check(cloud.normals.size(), "normals");
  check(cloud.colors.size(), "colors");
  check(cloud.observations.size(), "observations");
  for (const auto& triangle : cloud.triangles) {
    for (int32_t index : triangle) {
      if (index < 0 || static_cast<size_t>(index) >= n) {
        throw std::invalid_argument(fmt::format("PLY triangle index {} out of range", index));
      }
    }
  }
  for (const std::string& comment : cloud.comments) {
    if (comment.find_first_of("\r\n") != std::string::npos) {
      throw std::invalid_argument("PLY comment holds a line break");
    }
  }
}

// One property of the vertex element as read from a header.
struct Property {
  std::string name;
  std::string type;  // Canonical: char uchar short ushort int uint float double.
  size_t size = 0;
};

std::string CanonicalType(const std::string& type) {
  if (type == "int8") return "char";
  if (type == "uint8") return "uchar";
  if (type == "int16") return "short";
  if (type == "uint16") return "ushort";
  if (type == "int32") return "int";
  if (type == "uint32") return "uint";
  if (type == "float32") return "float";
  if (type == "float64") return "double";
  return type;
}

size_t TypeSize(const std::string& type) {
  if (type == "char" || type == "uchar") return 1;
  if (type == "short" || type == "ushort") return 2;
  if (type == "int" || type == "uint" || type == "float") return 4;
  if (type == "double") return 8;
  return 0;
}

double ReadBinaryValue(const char* p, const std::string& type) {
  const auto get = [p]<typename T>(T) {
    T v;
    std::memcpy(&v, p, sizeof(T));
    return static_cast<double>(v);
  };
  if (type == "char") return get(int8_t{});
  if (type == "uchar") return get(uint8_t{});
  if (type == "short") return get(int16_t{});
  if (type == "ushort") return get(uint16_t{});
  if (type == "int") return get(int32_t{});
  if (type == "uint") return get(uint32_t{});
  if (type == "float") return get(float{});
  return get(double{});
}

// Reads a PLY file's bytes into a cloud; every failure is a DataError naming
// `source`. The steps run in order: header, its checks, then the body.
class PlyParser {
 public:
  PlyParser(const std::string& bytes, const std::string& source) : bytes_(bytes), source_(source) {}

  PlyCloud Parse() {
    ReadHeader();
    CheckHeader();
    values_.resize(properties_.size());
    if (format_ == "ascii") {
      ReadAsciiBody();
    } else {
      ReadBinaryBody();
    }
    return std::move(cloud_);
  }

 private:
  DataError Fail(const std::string& why) const {
    return DataError(source_ + ": not a readable PLY file: " + why);
  }

  // Header: lines up to "end_header".
  void ReadHeader() {
    const size_t end = bytes_.find("end_header");
    if (bytes_.rfind("ply", 0) != 0 || end == std::string::npos) throw Fail("no PLY header");
    body_ = bytes_.find('\n', end);
    if (body_ == std::string::npos) throw Fail("header not terminated");
    std::istringstream header(bytes_.substr(0, end));
    std::string line;
    while (std::getline(header, line)) {
      if (!line.empty() && line.back() == '\r') line.pop_back();
      std::istringstream words(line);
      std::string keyword;
      words >> keyword;
      if (keyword == "format") {
        words >> format_;
      } else if (keyword == "comment") {
        cloud_.comments.push_back(line.size() > 8 ? line.substr(8) : "");
      } else if (keyword == "element") {
        ReadElement(&words, line);
      } else if (keyword == "property") {
        ReadProperty(&words, line);
      }
    }
  }

  // An "element" line (after its keyword): vertex and face counts.
  void ReadElement(std::istringstream* words, const std::string& line) {
    size_t count = 0;
    *words >> element_ >> count;
    if (!*words) throw Fail("bad element line '" + line + "'");
    if (element_ == "vertex") vertices_ = count;
    if (element_ == "face") faces_ = count;
    if (element_ != "vertex" && element_ != "face" && count != 0) {
      throw Fail("unsupported element '" + element_ + "'");
    }
  }

  // A "property" line (after its keyword) of the current element.
  void ReadProperty(std::istringstream* words, const std::string& line) {
    std::string type;
    *words >> type;
    if (element_ == "vertex") {
      Property property;
      property.type = CanonicalType(type);
      *words >> property.name;
      property.size = TypeSize(property.type);
      if (property.size == 0) throw Fail("unsupported vertex property '" + line + "'");
      properties_.push_back(property);
    } else if (element_ == "face") {
      std::string count_type, index_type, name;
      *words >> count_type >> index_type >> name;
      if (type != "list" || CanonicalType(count_type) != "uchar" ||
          TypeSize(CanonicalType(index_type)) != 4) {
        throw Fail("unsupported face property '" + line + "'");
      }
      face_list_ = true;
    }
  }

  // Refuses what the body cannot be read with; finds the vertex properties.
  void CheckHeader() {
    if (format_ != "ascii" && format_ != "binary_little_endian") {
      throw Fail("unsupported format '" + format_ + "'");
    }
    if (faces_ > 0 && !face_list_) throw Fail("faces without vertex_indices");
    x_ = IndexOf("x");
    y_ = IndexOf("y");
    z_ = IndexOf("z");
    if (x_ < 0 || y_ < 0 || z_ < 0) throw Fail("vertices without x, y, z");
    nx_ = IndexOf("nx");
    ny_ = IndexOf("ny");
    nz_ = IndexOf("nz");
    red_ = IndexOf("red");
    green_ = IndexOf("green");
    blue_ = IndexOf("blue");
    observations_ = IndexOf("scalar_observations");
    if (observations_ < 0) observations_ = IndexOf("observations");
    has_normals_ = nx_ >= 0 && ny_ >= 0 && nz_ >= 0;
    has_colors_ = red_ >= 0 && green_ >= 0 && blue_ >= 0;
  }

  // The index of the vertex property `name`; -1 when there is none.
  int IndexOf(const std::string& name) const {
    for (size_t i = 0; i < properties_.size(); ++i) {
      if (properties_[i].name == name) return static_cast<int>(i);
    }
    return -1;
  }

  void ReadAsciiBody() {
    std::istringstream in(bytes_.substr(body_ + 1));
    for (size_t i = 0; i < vertices_; ++i) {
      for (double& v : values_) {
        if (!(in >> v)) throw Fail(fmt::format("vertex {} of {} is short", i, vertices_));
      }
      StoreVertex();
    }
    for (size_t i = 0; i < faces_; ++i) {
      int count = 0;
      std::array<int32_t, 3> t{};
      if (!(in >> count >> t[0] >> t[1] >> t[2])) throw Fail(fmt::format("face {} is short", i));
      StoreTriangle(count, t);
    }
  }

  void ReadBinaryBody() {
    size_t stride = 0;
    for (const Property& p : properties_) stride += p.size;
    size_t offset = body_ + 1;
    if ((bytes_.size() - offset) / stride < vertices_) {
      throw Fail(fmt::format("{} vertices announced, fewer stored", vertices_));
    }
    for (size_t i = 0; i < vertices_; ++i) {
      for (size_t k = 0; k < properties_.size(); ++k) {
        values_[k] = ReadBinaryValue(bytes_.data() + offset, properties_[k].type);
        offset += properties_[k].size;
      }
      StoreVertex();
    }
    for (size_t i = 0; i < faces_; ++i) {
      if (bytes_.size() - offset < 13) throw Fail(fmt::format("face {} is short", i));
      const int count = static_cast<uint8_t>(bytes_[offset]);
      std::array<int32_t, 3> t{};
      std::memcpy(t.data(), bytes_.data() + offset + 1, 12);
      offset += 13;
      StoreTriangle(count, t);
    }
  }

  // Adds the vertex whose property values are in values_.
  void StoreVertex() {
    const std::vector<double>& values = values_;
    cloud_.positions.emplace_back(values[x_], values[y_], values[z_]);
    if (has_normals_) cloud_.normals.emplace_back(values[nx_], values[ny_], values[nz_]);
    if (has_colors_) {
      cloud_.colors.push_back({static_cast<uint8_t>(values[red_]),
                               static_cast<uint8_t>(values[green_]),
                               static_cast<uint8_t>(values[blue_])});
    }
    if (observations_ >= 0) {
      cloud_.observations.push_back(static_cast<int32_t>(values[observations_]));
    }
  }

  // Adds a face after checking it is a triangle of announced vertices.
  void StoreTriangle(int count, const std::array<int32_t, 3>& t) {
    if (count != 3) throw Fail(fmt::format("a face with {} vertices (triangles only)", count));
    for (int32_t index : t) {
      if (index < 0 || static_cast<size_t>(index) >= vertices_) {
        throw Fail(fmt::format("face index {} out of range", index));
      }
    }
    cloud_.triangles.push_back(t);
  }

  const std::string& bytes_;
  const std::string& source_;
  PlyCloud cloud_;
  // Header.
  size_t body_ = 0;      // Offset of the '\n' that ends the header.
  std::string format_;   // "ascii" or "binary_little_endian" once checked.
  std::string element_;  // The element whose properties follow.
  size_t vertices_ = 0, faces_ = 0;
  std::vector<Property> properties_;  // Of the vertex element, in order.
  bool face_list_ = false;            // The face element has vertex_indices.
  // Indices of the vertex properties in properties_; -1: absent.
  int x_ = -1, y_ = -1, z_ = -1, nx_ = -1, ny_ = -1, nz_ = -1;
  int red_ = -1, green_ = -1, blue_ = -1, observations_ = -1;
  bool has_normals_ = false, has_colors_ = false;
  std::vector<double> values_;  // One vertex's property values.
};

}  // namespace

std::string EncodePly(const PlyCloud& cloud, PlyFormat format) {
  CheckCloud(cloud);
  const bool binary = format == PlyFormat::kBinaryLittleEndian;
  const bool normals = !cloud.normals.empty();
  const bool colors = !cloud.colors.empty();
  const bool observations = !cloud.observations.empty();
  std::string out = "ply\n";
  out += binary ? "format binary_little_endian 1.0\n" : "format ascii 1.0\n";
  for (const std::string& comment : cloud.comments) out += "comment " + comment + "\n";
  out += fmt::format("element vertex {}\n", cloud.positions.size());
  out += "property float x\nproperty float y\nproperty float z\n";
  if (normals) out += "property float nx\nproperty float ny\nproperty float nz\n";
  if (colors) out += "property uchar red\nproperty uchar green\nproperty uchar blue\n";
  if (observations) out += "property int scalar_observations\n";
  if (!cloud.triangles.empty()) {
    out += fmt::format("element face {}\n", cloud.triangles.size());
    out += "property list uchar int vertex_indices\n";
  }
  out += "end_header\n";

  for (size_t i = 0; i < cloud.positions.size(); ++i) {
    const Eigen::Vector3f& p = cloud.positions[i];
    if (binary) {
      for (int k = 0; k < 3; ++k) Append(&out, p[k]);
      if (normals) {
        for (int k = 0; k < 3; ++k) Append(&out, cloud.normals[i][k]);
      }
      if (colors) {
        for (int k = 0; k < 3; ++k) Append(&out, cloud.colors[i][k]);
      }
      if (observations) Append(&out, cloud.observations[i]);
    } else {
      // %.9g round-trips a float exactly.
      out += fmt::format("{:.9g} {:.9g} {:.9g}", p.x(), p.y(), p.z());
      if (normals) {
        const Eigen::Vector3f& n = cloud.normals[i];
        out += fmt::format(" {:.9g} {:.9g} {:.9g}", n.x(), n.y(), n.z());
      }
      if (colors) {
        const auto& c = cloud.colors[i];
        out += fmt::format(" {} {} {}", c[0], c[1], c[2]);
      }
      if (observations) out += fmt::format(" {}", cloud.observations[i]);
      out += '\n';
    }
  }
  for (const auto& t : cloud.triangles) {
    if (binary) {
      Append(&out, uint8_t{3});
      for (int32_t index : t) Append(&out, index);
    } else {
      out += fmt::format("3 {} {} {}\n", t[0], t[1], t[2]);
    }
  }
  return out;
}

void WritePly(const std::filesystem::path& path, const PlyCloud& cloud, PlyFormat format) {
  WriteFileAtomically(path, EncodePly(cloud, format));
}

PlyCloud ReadPly(const std::filesystem::path& path) {
  return ParsePly(ReadFileToString(path), path.string());
}

PlyCloud ParsePly(const std::string& bytes, const std::string& source) {
  return PlyParser(bytes, source).Parse();
}

}  // namespace rrslam
