#include "fleet/engine_kubernetes.hpp"

#include <fmt/core.h>

#include <cmath>

#include "fleet/engine_local.hpp"
#include "fleet/engine_slurm.hpp"
#include "files/atomic_file.hpp"

namespace insalign::fleet {
namespace {

namespace fs = std::filesystem;

// The deepest folder holding both paths: what the volume is mounted at.
fs::path common_root(const fs::path& a, const fs::path& b) {
  fs::path root;
  auto ia = a.begin(), ib = b.begin();
  for (; ia != a.end() && ib != b.end() && *ia == *ib; ++ia, ++ib) root /= *ia;
  return root.empty() ? fs::path("/") : root;
}

// YAML double-quoted scalar.
std::string quoted(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out + "\"";
}

}  // namespace

std::string kubernetes_job_yaml(const Manifest& m, const fs::path& results_in, const KubernetesConfig& c) {
  const fs::path results = fs::absolute(results_in).lexically_normal();
  const fs::path mount = common_root(m.folder, results);
  std::uintmax_t largest = 0;
  for (const ManifestRow& row : m.rows) largest = std::max(largest, recording_bytes(m, row));
  const int memory_mb = static_cast<int>(std::ceil(c.base_memory_mb + c.memory_mb_per_gb * static_cast<double>(largest) / 1e9));
  std::string command;
  for (const std::string& a : task_command(c.exe, m, results, c.force)) command += (command.empty() ? "" : ", ") + quoted(a);
  std::string y;
  y += "# insalign fleet: one completion index per manifest row; every pod runs `insalign fleet task`,\n";
  y += "# which takes its row from JOB_COMPLETION_INDEX. Apply with: kubectl apply -f fleet-job.yaml\n";
  y += "apiVersion: batch/v1\nkind: Job\nmetadata:\n  generateName: insalign-fleet-\n  labels:\n    app: insalign-fleet\n";
  y += "spec:\n  completionMode: Indexed\n";
  y += fmt::format("  completions: {}\n  parallelism: {}\n", m.rows.size(), std::max<std::size_t>(1, c.jobs));
  y += fmt::format("  backoffLimitPerIndex: {}\n  maxFailedIndexes: {}\n", c.backoff_limit_per_index, m.rows.size());
  y += "  podFailurePolicy:\n    rules:\n";
  // Exit codes 1 and 2 are the row's own failure, written in its status: retrying cannot help.
  y += "    - action: FailIndex\n      onExitCodes:\n        containerName: task\n        operator: In\n        values: [1, 2]\n";
  y += "    - action: Ignore\n      onPodConditions:\n      - type: DisruptionTarget\n";
  y += "  template:\n    metadata:\n      labels:\n        app: insalign-fleet\n    spec:\n      restartPolicy: Never\n";
  y += "      containers:\n      - name: task\n        image: " + quoted(c.image) + "\n";
  y += "        command: [" + command + "]\n";
  // Set by the Job controller for Indexed Jobs; spelled out so the task's source of its row is visible.
  y += "        env:\n        - name: JOB_COMPLETION_INDEX\n          valueFrom:\n            fieldRef:\n"
       "              fieldPath: metadata.annotations['batch.kubernetes.io/job-completion-index']\n";
  y += fmt::format("        resources:\n          requests:\n            cpu: \"{}\"\n            memory: {}Mi\n", c.cpus, memory_mb);
  y += fmt::format("          limits:\n            memory: {}Mi\n", memory_mb);
  y += "        volumeMounts:\n        - name: fleet-data\n          mountPath: " + quoted(mount.string()) + "\n";
  y += "      volumes:\n      - name: fleet-data\n        persistentVolumeClaim:\n          claimName: " + quoted(c.volume_claim) + "\n";
  return y;
}

std::string dockerfile() {
  return "# The insalign image for the fleet's Kubernetes Job. Build from the insalign source folder:\n"
         "#   docker build -f RESULTS/kubernetes/Dockerfile -t insalign:latest .\n"
         "FROM debian:12\n"
         "COPY scripts/install-deps.sh /src/scripts/install-deps.sh\n"
         "# The same Debian packages as a machine set up by scripts/install-deps.sh.\n"
         "RUN bash /src/scripts/install-deps.sh && rm -rf /var/lib/apt/lists/*\n"
         "COPY . /src\n"
         "RUN cd /src && bash scripts/build.sh -DINSALIGN_BUILD_TESTS=OFF && install -m 755 build/src/insalign /usr/local/bin/insalign\n"
         "ENTRYPOINT [\"/usr/local/bin/insalign\"]\n";
}

fs::path write_kubernetes(const Manifest& m, const fs::path& results, const KubernetesConfig& c) {
  const fs::path dir = fs::absolute(results) / "kubernetes";
  fs::create_directories(dir);
  io::write_file_atomic(dir / "fleet-job.yaml", kubernetes_job_yaml(m, results, c));
  io::write_file_atomic(dir / "Dockerfile", dockerfile());
  return dir / "fleet-job.yaml";
}

}  // namespace insalign::fleet
