#include "stages/cluster/vocab_tree.h"

#include "common/atomic_file.h"
#include "common/errors.h"
#include "common/formats.h"

namespace rrslam {

std::vector<std::pair<uint32_t, uint32_t>> VocabTree::ChildRanges() const {
  std::vector<std::pair<uint32_t, uint32_t>> ranges(parent.size(), {0, 0});
  for (size_t i = 1; i < parent.size(); ++i) {
    auto& r = ranges[static_cast<size_t>(parent[i])];
    if (r.second == 0) r.first = static_cast<uint32_t>(i);
    ++r.second;
  }
  return ranges;
}

size_t VocabTree::NumLeaves() const {
  std::vector<uint8_t> has_child(parent.size(), 0);
  for (size_t i = 1; i < parent.size(); ++i) has_child[static_cast<size_t>(parent[i])] = 1;
  size_t leaves = 0;
  for (size_t i = 1; i < parent.size(); ++i) leaves += has_child[i] == 0;
  return leaves;
}

void ValidateVocabTree(const VocabTree& tree, const std::string& source) {
  const size_t n = tree.parent.size();
  auto fail = [&](const std::string& what) { throw DataError(source + ": " + what); };
  if (tree.k < 1 || tree.k > 31) fail("k = " + std::to_string(tree.k) + " is not in [1, 31]");
  if (tree.levels < 1 || tree.levels > 255) {
    fail("levels = " + std::to_string(tree.levels) + " is not in [1, 255]");
  }
  if (tree.level.size() != n || tree.centre.size() != n || tree.count.size() != n) {
    fail("node arrays differ in length");
  }
  if (n < 2) fail("the tree has no node besides the root");
  if (tree.parent[0] != -1 || tree.level[0] != 0) fail("node 0 is not a root (parent -1, level 0)");
  // Running state of the sibling group being read: siblings must be contiguous.
  std::vector<uint32_t> num_children(n, 0);
  std::vector<uint64_t> child_count_sum(n, 0);
  for (size_t i = 1; i < n; ++i) {
    const int32_t p = tree.parent[i];
    const std::string node = "node " + std::to_string(i);
    if (p < 0 || static_cast<size_t>(p) >= i) {
      fail(node + " has parent " + std::to_string(p) + "; parents must precede their children");
    }
    if (tree.level[i] != tree.level[static_cast<size_t>(p)] + 1 || tree.level[i] > tree.levels) {
      fail(node + " has level " + std::to_string(tree.level[i]) + " (parent level " +
           std::to_string(tree.level[static_cast<size_t>(p)]) +
           ", L = " + std::to_string(tree.levels) + ")");
    }
    if (num_children[static_cast<size_t>(p)] > 0 && tree.parent[i - 1] != p) {
      fail("the children of node " + std::to_string(p) + " are not contiguous (at " + node + ")");
    }
    if (++num_children[static_cast<size_t>(p)] > static_cast<uint32_t>(tree.k)) {
      fail("node " + std::to_string(p) + " has more than k = " + std::to_string(tree.k) +
           " children");
    }
    if (tree.count[i] == 0) fail(node + " holds no descriptor");
    child_count_sum[static_cast<size_t>(p)] += tree.count[i];
  }
  for (size_t i = 0; i < n; ++i) {
    if (num_children[i] > 0 && child_count_sum[i] != tree.count[i]) {
      fail("node " + std::to_string(i) + " holds " + std::to_string(tree.count[i]) +
           " descriptors but its children hold " + std::to_string(child_count_sum[i]));
    }
  }
}

void WriteVocabTree(const std::filesystem::path& path, const VocabTree& tree,
                    const std::string& producer, const nlohmann::json& options) {
  AtomicOutput out(path);
  {
    H5::H5File file = CreateH5File(out.temp_path());
    try {
      WriteFormatAttributes(file, kVocabTreeFormat, producer, options);
      WriteH5ScalarAttribute(file, "k", tree.k, H5::PredType::STD_I32LE);
      WriteH5ScalarAttribute(file, "levels", tree.levels, H5::PredType::STD_I32LE);
      WriteH5ScalarAttribute(file, "num_descriptors",
                             static_cast<double>(tree.count.empty() ? 0 : tree.count[0]),
                             H5::PredType::STD_U64LE);
      // Stored uncompressed: centres are nearly random bits (deflate saves
      // little and costs more than the clustering of the last level).
      const hsize_t n = tree.num_nodes();
      H5::Group nodes = CreateH5Group(file, "nodes");
      WriteH5Array<int32_t>(nodes, "parent", tree.parent, {n});
      WriteH5Array<uint8_t>(nodes, "level", tree.level, {n});
      WriteH5Array(nodes, "centre", tree.centre.data(), H5::PredType::NATIVE_UINT8, {n, 32}, 0);
      WriteH5Array<uint64_t>(nodes, "count", tree.count, {n});
      file.close();
    } catch (const H5::Exception& e) {
      throw CantCreateError(path.string() + ": HDF5 write failed: " + e.getDetailMsg());
    }
  }
  out.Commit();
}

namespace {

// The body of ReadVocabTree and ReadVocabTreeImage: everything after the root
// attributes were checked.
VocabTree ReadTree(const H5::H5File& file, const std::string& name) {
  VocabTree tree;
  try {
    const double k = ReadH5ScalarAttribute(file, "k", name);
    const double levels = ReadH5ScalarAttribute(file, "levels", name);
    if (!(k >= 1 && k <= 31) || !(levels >= 1 && levels <= 255)) {
      throw DataError(name + ": attributes k or levels out of range");
    }
    tree.k = static_cast<int>(k);
    tree.levels = static_cast<int>(levels);
    if (!file.nameExists("nodes") || file.childObjType("nodes") != H5O_TYPE_GROUP) {
      throw DataError(name + ": missing group nodes");
    }
    H5::Group nodes = file.openGroup("nodes");
    tree.parent = ReadH5Array<int32_t>(nodes, "parent", name, nullptr, 1);
    tree.level = ReadH5Array<uint8_t>(nodes, "level", name, nullptr, 1);
    tree.count = ReadH5Array<uint64_t>(nodes, "count", name, nullptr, 1);
    const std::vector<hsize_t> shape = H5ArrayShape(nodes, "centre", name);
    if (shape.size() != 2 || shape[1] != 32 || shape[0] != tree.parent.size()) {
      throw DataError(name + ": nodes/centre must be N x 32 bytes with N = nodes/parent length");
    }
    tree.centre.resize(tree.parent.size());
    if (!tree.centre.empty()) {
      ReadH5Array(nodes, "centre", tree.centre.data(), H5::PredType::NATIVE_UINT8, name);
    }
  } catch (const H5::Exception& e) {
    throw DataError(name + ": HDF5 read failed: " + e.getDetailMsg());
  }
  ValidateVocabTree(tree, name);
  return tree;
}

}  // namespace

VocabTree ReadVocabTree(const std::filesystem::path& path, H5FormatInfo* info) {
  return ReadTree(OpenH5File(path, kVocabTreeFormat, info), path.string());
}

VocabTree ReadVocabTreeImage(std::span<const uint8_t> bytes, const std::string& name,
                             H5FormatInfo* info) {
  return ReadTree(OpenH5FileImage(bytes, kVocabTreeFormat, name, info), name);
}

}  // namespace rrslam
