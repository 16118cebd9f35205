// The Kubernetes engine: an Indexed Job (one completion index per row, the index from
// JOB_COMPLETION_INDEX) ready for `kubectl apply -f`, and the Dockerfile of its image.
#pragma once

#include <filesystem>
#include <string>

#include "fleet/manifest.hpp"

namespace insalign::fleet {

struct KubernetesConfig {
  std::size_t jobs = 2;                      ///< --jobs: the Job's parallelism
  bool force = false;                        ///< --force: rerun done rows
  std::string image = "insalign:latest";     ///< --image: built from the Dockerfile written beside the Job
  std::string volume_claim = "insalign-fleet";  ///< --volume-claim: PersistentVolumeClaim holding the manifest, recordings and results
  int backoff_limit_per_index = 2;           ///< retries of one row (a lost node, an eviction)
  int cpus = 2;                              ///< requested cores per task
  double base_memory_mb = 1024.0;            ///< memory per task: base + memory_mb_per_gb * largest recording
  double memory_mb_per_gb = 1024.0;
  std::filesystem::path exe = "/usr/local/bin/insalign";  ///< the binary inside the image
};

/// The Job manifest. The volume is mounted at the folder holding both the manifest and the
/// results, at the same absolute path as here, so that every path in the manifest stays valid.
std::string kubernetes_job_yaml(const Manifest& m, const std::filesystem::path& results, const KubernetesConfig& config);

/// A Debian 12 image that installs the packages of scripts/install-deps.sh and builds insalign.
std::string dockerfile();

/// Writes DIR/kubernetes/fleet-job.yaml and DIR/kubernetes/Dockerfile; returns the Job's path.
std::filesystem::path write_kubernetes(const Manifest& m, const std::filesystem::path& results, const KubernetesConfig& config);

}  // namespace insalign::fleet
