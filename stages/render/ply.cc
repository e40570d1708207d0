#include "stages/render/ply.h"

#include <fmt/format.h>

#include <bit>
#include <cstring>
#include <sstream>
#include <stdexcept>

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
  if (observations) out += "property int observations\n";
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
  const auto fail = [&source](const std::string& why) -> DataError {
    return DataError(source + ": not a readable PLY file: " + why);
  };
  // Header: lines up to "end_header".
  const size_t end = bytes.find("end_header");
  if (bytes.rfind("ply", 0) != 0 || end == std::string::npos) throw fail("no PLY header");
  const size_t body = bytes.find('\n', end);
  if (body == std::string::npos) throw fail("header not terminated");
  std::istringstream header(bytes.substr(0, end));
  std::string line, format;
  size_t vertices = 0, faces = 0;
  std::vector<Property> properties;
  std::string element;
  bool face_list = false;
  PlyCloud cloud;
  while (std::getline(header, line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    std::istringstream words(line);
    std::string keyword;
    words >> keyword;
    if (keyword == "format") {
      words >> format;
    } else if (keyword == "comment") {
      cloud.comments.push_back(line.size() > 8 ? line.substr(8) : "");
    } else if (keyword == "element") {
      size_t count = 0;
      words >> element >> count;
      if (!words) throw fail("bad element line '" + line + "'");
      if (element == "vertex") vertices = count;
      if (element == "face") faces = count;
      if (element != "vertex" && element != "face" && count != 0) {
        throw fail("unsupported element '" + element + "'");
      }
    } else if (keyword == "property") {
      std::string type;
      words >> type;
      if (element == "vertex") {
        Property property;
        property.type = CanonicalType(type);
        words >> property.name;
        property.size = TypeSize(property.type);
        if (property.size == 0) throw fail("unsupported vertex property '" + line + "'");
        properties.push_back(property);
      } else if (element == "face") {
        std::string count_type, index_type, name;
        words >> count_type >> index_type >> name;
        if (type != "list" || CanonicalType(count_type) != "uchar" ||
            TypeSize(CanonicalType(index_type)) != 4) {
          throw fail("unsupported face property '" + line + "'");
        }
        face_list = true;
      }
    }
  }
  if (format != "ascii" && format != "binary_little_endian") {
    throw fail("unsupported format '" + format + "'");
  }
  if (faces > 0 && !face_list) throw fail("faces without vertex_indices");
  const auto index_of = [&properties](const std::string& name) -> int {
    for (size_t i = 0; i < properties.size(); ++i) {
      if (properties[i].name == name) return static_cast<int>(i);
    }
    return -1;
  };
  const int x = index_of("x"), y = index_of("y"), z = index_of("z");
  if (x < 0 || y < 0 || z < 0) throw fail("vertices without x, y, z");
  const int nx = index_of("nx"), ny = index_of("ny"), nz = index_of("nz");
  const int red = index_of("red"), green = index_of("green"), blue = index_of("blue");
  const int observations = index_of("observations");
  const bool has_normals = nx >= 0 && ny >= 0 && nz >= 0;
  const bool has_colors = red >= 0 && green >= 0 && blue >= 0;

  std::vector<double> values(properties.size());
  const auto store = [&](size_t) {
    cloud.positions.emplace_back(values[x], values[y], values[z]);
    if (has_normals) cloud.normals.emplace_back(values[nx], values[ny], values[nz]);
    if (has_colors) {
      cloud.colors.push_back({static_cast<uint8_t>(values[red]),
                              static_cast<uint8_t>(values[green]),
                              static_cast<uint8_t>(values[blue])});
    }
    if (observations >= 0) cloud.observations.push_back(static_cast<int32_t>(values[observations]));
  };
  const auto check_triangle = [&](int count, const std::array<int32_t, 3>& t) {
    if (count != 3) throw fail(fmt::format("a face with {} vertices (triangles only)", count));
    for (int32_t index : t) {
      if (index < 0 || static_cast<size_t>(index) >= vertices) {
        throw fail(fmt::format("face index {} out of range", index));
      }
    }
    cloud.triangles.push_back(t);
  };
  if (format == "ascii") {
    std::istringstream in(bytes.substr(body + 1));
    for (size_t i = 0; i < vertices; ++i) {
      for (double& v : values) {
        if (!(in >> v)) throw fail(fmt::format("vertex {} of {} is short", i, vertices));
      }
      store(i);
    }
    for (size_t i = 0; i < faces; ++i) {
      int count = 0;
      std::array<int32_t, 3> t{};
      if (!(in >> count >> t[0] >> t[1] >> t[2])) throw fail(fmt::format("face {} is short", i));
      check_triangle(count, t);
    }
  } else {
    size_t stride = 0;
    for (const Property& p : properties) stride += p.size;
    size_t offset = body + 1;
    if ((bytes.size() - offset) / stride < vertices) {
      throw fail(fmt::format("{} vertices announced, fewer stored", vertices));
    }
    for (size_t i = 0; i < vertices; ++i) {
      for (size_t k = 0; k < properties.size(); ++k) {
        values[k] = ReadBinaryValue(bytes.data() + offset, properties[k].type);
        offset += properties[k].size;
      }
      store(i);
    }
    for (size_t i = 0; i < faces; ++i) {
      if (bytes.size() - offset < 13) throw fail(fmt::format("face {} is short", i));
      const int count = static_cast<uint8_t>(bytes[offset]);
      std::array<int32_t, 3> t{};
      std::memcpy(t.data(), bytes.data() + offset + 1, 12);
      offset += 13;
      check_triangle(count, t);
    }
  }
  return cloud;
}

}  // namespace rrslam
