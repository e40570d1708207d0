#include "stages/cluster/cluster.h"

#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>

#include "common/cli.h"
#include "common/errors.h"
#include "common/output_path.h"
#include "common/progress.h"
#include "common/worker_pool.h"
#include "stages/cluster/hkmeans.h"
#include "stages/extract/features_file.h"

namespace rrslam {

bool ClusterOptions::Check(std::string* why) const {
  auto fail = [&](const std::string& text) {
    if (why != nullptr) *why = text;
    return false;
  };
  if (features.empty()) return fail("features: at least one features file is required");
  if (out.empty()) return fail("out: an output tree file is required");
  std::vector<NamedPath> inputs;
  for (const auto& f : features) inputs.push_back({"--features", f});
  std::string clash;
  if (!CheckOutputNotInput({"--out", out}, inputs, &clash)) return fail(clash);
  if (k < 2 || k > 20) return fail("k = " + std::to_string(k) + "; must be in [2, 20]");
  if (levels < 1 || levels > 10) {
    return fail("levels = " + std::to_string(levels) + "; must be in [1, 10]");
  }
  if (threads < 0 || threads > kMaxThreads) {
    return fail("threads = " + std::to_string(threads) + "; must be in [0, " +
                std::to_string(kMaxThreads) + "] (0 = all cores)");
  }
  if (stride < 1) return fail("stride = " + std::to_string(stride) + "; must be >= 1");
  if (max_iterations < 1) {
    return fail("max_iterations = " + std::to_string(max_iterations) + "; must be >= 1");
  }
  return true;
}

nlohmann::json ClusterOptions::ToJson() const {
  nlohmann::json files = nlohmann::json::array();
  for (const auto& f : features) files.push_back(f.string());
  return {{"features", files},
          {"out", out.string()},
          {"k", k},
          {"levels", levels},
          {"seed", seed},
          {"threads", threads},
          {"stride", stride},
          {"max_descriptors", max_descriptors},
          {"max_iterations", max_iterations}};
}

void BindClusterOptions(CLI::App& app, ClusterOptions* o) {
  app.add_option("--features", o->features, "Features files (rrslam-extract output), one or more")
      ->required()
      ->expected(1, -1);
  app.add_option("--out", o->out, "Output vocabulary tree (HDF5)")->required();
  app.add_option("--k", o->k, "Branching factor: clusters per node, [2, 20]")
      ->capture_default_str();
  app.add_option("--levels,-L", o->levels, "Depth of the tree, [1, 10]")->capture_default_str();
  app.add_option("--seed", o->seed, "Random seed (same seed, same tree)")->capture_default_str();
  app.add_option("--threads", o->threads,
                 "Worker threads, in [0, 256], 0 = all cores (never changes the tree)")
      ->capture_default_str();
  app.add_option("--stride", o->stride, "Use every N-th frame of each features file")
      ->capture_default_str();
  app.add_option("--max-descriptors", o->max_descriptors,
                 "Cluster a seeded random subset of at most N descriptors, 0 = all")
      ->capture_default_str();
  app.add_option("--max-iterations", o->max_iterations, "Cap on k-means assignment rounds per node")
      ->capture_default_str();
}

namespace {

// Keeps a seeded uniform random subset of `keep` descriptors, in input order
// (partial Fisher-Yates over indices with SplitMix64).
void Subsample(std::vector<OrbDescriptor>* descriptors, size_t keep, uint64_t seed) {
  const size_t n = descriptors->size();
  if (keep >= n) return;
  std::vector<uint32_t> index(n);
  for (size_t i = 0; i < n; ++i) index[i] = static_cast<uint32_t>(i);
  uint64_t state = seed ^ 0x5bd1e9955bd1e995ULL;
  auto next = [&state] {
    uint64_t z = (state += 0x9e3779b97f4a7c15ULL);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
  };
  for (size_t i = 0; i < keep; ++i) {
    const size_t j =
        i + static_cast<size_t>((static_cast<unsigned __int128>(next()) * (n - i)) >> 64);
    std::swap(index[i], index[j]);
  }
  index.resize(keep);
  std::sort(index.begin(), index.end());
  std::vector<OrbDescriptor> kept(keep);
  for (size_t i = 0; i < keep; ++i) kept[i] = (*descriptors)[index[i]];
  descriptors->swap(kept);
}

}  // namespace

VocabTree RunCluster(const ClusterOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw UsageError(why);
  const auto start = std::chrono::steady_clock::now();

  std::vector<OrbDescriptor> descriptors;
  for (const auto& path : options.features) {
    std::vector<OrbDescriptor> d =
        ReadFeatureDescriptors(path, static_cast<size_t>(options.stride));
    spdlog::info("cluster: {} descriptors from {}", d.size(), path.string());
    if (descriptors.empty()) {
      descriptors.swap(d);
    } else {
      descriptors.insert(descriptors.end(), d.begin(), d.end());
    }
  }
  if (descriptors.empty()) {
    throw AlgorithmError("no descriptors in the features files: nothing to cluster");
  }
  if (options.max_descriptors > 0 && descriptors.size() > options.max_descriptors) {
    spdlog::info("cluster: keeping a random subset of {} of {} descriptors",
                 options.max_descriptors, descriptors.size());
    Subsample(&descriptors, options.max_descriptors, options.seed);
  }

  HkmeansParams params;
  params.k = options.k;
  params.levels = options.levels;
  params.seed = options.seed;
  params.threads = options.threads;
  params.max_iterations = options.max_iterations;
  VocabTree tree;
  {
    ProgressBar progress("cluster", descriptors.size(), "desc");
    tree = BuildVocabTree(descriptors, params, &progress);
  }
  nlohmann::json recorded = options.ToJson();
  recorded["num_descriptors"] = tree.count[0];
  WriteVocabTree(options.out, tree, Producer("cluster"), recorded);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  spdlog::info("cluster: {} nodes, {} leaves from {} descriptors in {:.2f} s -> {}",
               tree.num_nodes(), tree.NumLeaves(), tree.count[0], seconds, options.out.string());
  return tree;
}

}  // namespace rrslam
