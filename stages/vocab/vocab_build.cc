#include "stages/vocab/vocab_build.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <thread>

#include "common/errors.h"
#include "common/worker_pool.h"

namespace rrslam {

VocabularyData VocabularyFromTree(const VocabTree& tree, WeightingType weighting,
                                  ScoringType scoring, const std::string& source) {
  ValidateVocabTree(tree, source);
  VocabularyData data;
  data.info.k = tree.k;
  data.info.levels = tree.levels;
  data.info.weighting = weighting;
  data.info.scoring = scoring;
  std::vector<uint32_t> parents(tree.num_nodes(), 0);
  for (size_t i = 1; i < parents.size(); ++i) parents[i] = static_cast<uint32_t>(tree.parent[i]);
  data.Allocate(tree.num_nodes());
  LinksFromParents(parents, &data.info, data.links(), source);
  std::copy(tree.centre.begin(), tree.centre.end(), data.descriptors().begin());
  data.descriptors()[0] = OrbDescriptor{};
  std::fill(data.weights().begin(), data.weights().end(), 0.0f);
  return data;
}

void SetWordWeights(std::span<const std::span<const OrbDescriptor>> images, int threads,
                    VocabularyData* data, ProgressBar* progress) {
  const size_t n = data->info.num_nodes;
  std::fill(data->weights().begin(), data->weights().end(), 0.0f);
  const WeightingType w = data->info.weighting;
  if (w == WeightingType::kTf || w == WeightingType::kBinary) {
    // The idf part is 1 for every word.
    for (size_t i = 0; i < n; ++i) {
      if (LinkChildren(data->links()[i]) == 0 && i > 0) data->weights()[i] = 1.0f;
    }
    return;
  }
  // N_i per leaf node: images are counted by several threads, each into its
  // own integer counts, which are then summed (exact, order-free).
  const int num_threads = std::max(
      1,
      std::min<int>(threads > 0 ? threads : static_cast<int>(std::thread::hardware_concurrency()),
                    static_cast<int>(images.size())));
  const VocabularyView view = data->view();
  std::vector<std::vector<uint32_t>> counts(num_threads, std::vector<uint32_t>(n, 0));
  std::atomic<size_t> next{0};
  auto work = [&](int t) {
    std::vector<uint32_t>& count = counts[t];
    std::vector<uint32_t> leaves;
    for (size_t image = next++; image < images.size(); image = next++) {
      leaves.clear();
      for (const OrbDescriptor& d : images[image]) leaves.push_back(DescendToLeaf(view, d));
      std::sort(leaves.begin(), leaves.end());
      leaves.erase(std::unique(leaves.begin(), leaves.end()), leaves.end());
      for (uint32_t leaf : leaves) ++count[leaf];
      if (progress != nullptr) progress->Advance();
    }
  };
  // Index t counts into counts[t]; each index runs once, on one thread. A
  // thread that cannot be started is a ResourceError (WorkerPool).
  WorkerPool pool(num_threads);
  pool.ParallelFor(static_cast<size_t>(num_threads), [&](size_t t) { work(static_cast<int>(t)); });
  const double num_images = static_cast<double>(images.size());
  for (size_t i = 1; i < n; ++i) {
    if (LinkChildren(data->links()[i]) != 0) continue;
    uint64_t images_with_word = 0;
    for (const auto& c : counts) images_with_word += c[i];
    if (images_with_word > 0) {
      data->weights()[i] =
          static_cast<float>(std::log(num_images / static_cast<double>(images_with_word)));
    }
  }
}

}  // namespace rrslam
