// Fuzz-only: the objects of a well-formed rrslam.vocab_tree file
// (vocab_tree.h) for common/fuzz/h5_image_builder.h, with the tree's shape
// taken from the fuzz input. Used by vocab_tree_fuzzer.cc and checked by
// vocab_tree_seeds_test.cc (a well-formed description must read back): a
// change of the tree schema must be made here too.
#pragma once

#include <vector>

#include "common/fuzz/h5_image_builder.h"

namespace rrslam::fuzz {

// k = input in [1, 4], L = input in [1, 3]; nodes split depth-first (as
// rrslam-cluster numbers them), the root into 1 to k children and every
// other node above level L into 0 (a leaf) to k, at most 160 nodes; leaves
// hold 1 to 3 descriptors, inner nodes the sum of their children's.
inline std::vector<H5Object> VocabTreeObjects(FuzzInput& in) {
  using Kind = H5Object::Kind;
  const int k = 1 + static_cast<int>(in.Below(4));
  const int levels = 1 + static_cast<int>(in.Below(3));
  std::vector<double> parent = {-1}, level = {0};
  std::vector<size_t> stack = {0};
  while (!stack.empty()) {
    const size_t node = stack.back();
    stack.pop_back();
    if (level[node] >= levels || parent.size() + k > 160) continue;
    const int children = node == 0 ? 1 + static_cast<int>(in.Below(k)) : in.Below(k + 1);
    const size_t first = parent.size();
    for (int c = 0; c < children; ++c) {
      parent.push_back(static_cast<double>(node));
      level.push_back(level[node] + 1);
    }
    for (int c = children - 1; c >= 0; --c) stack.push_back(first + static_cast<size_t>(c));
  }
  const size_t n = parent.size();
  std::vector<double> count(n, 0);
  for (size_t i = n; i-- > 1;) {
    if (count[i] == 0) count[i] = 1 + in.Below(3);  // A leaf: its children come after it.
    count[static_cast<size_t>(parent[i])] += count[i];
  }
  std::vector<double> centre(32 * n);
  for (size_t i = 32; i < centre.size(); ++i) centre[i] = static_cast<double>((i * 29) % 256);
  auto attribute = [](const char* name, hid_t type, double value) {
    return H5Object{Kind::kAttribute, name, type, false, {}, {value}, {}};
  };
  auto text_attribute = [](const char* name, const char* value) {
    return H5Object{Kind::kAttribute, name, H5T_NATIVE_DOUBLE, true, {}, {}, {value}};
  };
  const hsize_t N = n;
  return {
      text_attribute("format", "rrslam.vocab_tree"),
      attribute("format_major", H5T_STD_U16LE, 1),
      attribute("format_minor", H5T_STD_U16LE, 0),
      text_attribute("producer", "rrslam-cluster fuzz"),
      text_attribute("options", "{\"k\":2}"),
      attribute("k", H5T_STD_I32LE, k),
      attribute("levels", H5T_STD_I32LE, levels),
      attribute("num_descriptors", H5T_STD_U64LE, count[0]),
      H5Object{Kind::kGroup, "nodes", H5T_NATIVE_DOUBLE, false, {}, {}, {}},
      H5Object{Kind::kDataset, "nodes/parent", H5T_STD_I32LE, false, {N}, parent, {}},
      H5Object{Kind::kDataset, "nodes/level", H5T_STD_U8LE, false, {N}, level, {}},
      H5Object{Kind::kDataset, "nodes/centre", H5T_STD_U8LE, false, {N, 32}, centre, {}},
      H5Object{Kind::kDataset, "nodes/count", H5T_STD_U64LE, false, {N}, count, {}},
  };
}

}  // namespace rrslam::fuzz
