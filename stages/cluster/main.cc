// rrslam-cluster: hierarchical k-means of ORB descriptors into a vocabulary tree.
#include <CLI/CLI.hpp>

#include "common/cli.h"
#include "stages/cluster/cluster.h"

int main(int argc, char** argv) {
  rrslam::ClusterOptions options;
  return rrslam::RunTool(
      argc, argv,
      {"cluster",
       "Clusters the ORB descriptors of features files into a vocabulary tree (hierarchical "
       "k-means, Hamming distance, k-means++ seeding), written to HDF5 for `rrslam-vocab build`."},
      [&](CLI::App& app) { rrslam::BindClusterOptions(app, &options); },
      [&] { rrslam::RunCluster(options); });
}
